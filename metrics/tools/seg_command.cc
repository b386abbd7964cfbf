#include "metrics/tools/seg_command.h"

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "metrics/image_io.h"
#include "metrics/segmentation/mask_source.h"
#include "metrics/segmentation/seg_config.h"
#include "metrics/segmentation/segmented_mse.h"

namespace wm::metrics {
namespace {

constexpr const char* kFooter = R"(
MSE^r = mean over the frames where region r is present of the MSE over r's pixels (all channels),
r in {arm, object, background}, the regions taken from the REFERENCE frame and applied to both
(Quevedo, Liang, Yang, "Evaluating Robot Policies in a World Model", eq. 3). Squared data units
like wm-metrics' mse (divide by data_range^2 for [0, 1] units). A region absent from every frame
is null, never 0.

Mask sources (--masks):
  files   --mask-dir M: one label image per reference frame (sorted by name), mapped to regions
          by --labels 0=background,1=arm,2=object or the config's `labels`
  motion  the reference video itself: per-pixel background colour, shadow-tolerant change
          detection, connected parts entering from the arm's border (arm/background only)
  depth   --depth D (one depth image per frame) and --intrinsics fx,fy,cx,cy: RANSAC table
          plane, Euclidean clusters; the border-touching cluster is the arm, the others objects

Output (JSON, schemas/segmented-mse.schema.json): masks, frames, data_range, mse, mse_arm,
mse_object, mse_background, frames_arm, frames_object, frames_background, and with --per-frame
per_frame [{frame, mse, mse_<region>, pixels_<region>}]. CSV: frame,mse,mse_arm,mse_object,
mse_background,pixels_arm,pixels_object,pixels_background; a row per frame (--per-frame), then
"mean"; null is an empty cell.

Examples:
  wm-metrics seg --ref real/ --pred rollout/ --masks files --mask-dir real_seg/ \
      --config configs/segmentation/tabletop.yaml
  wm-metrics seg --ref real.mp4 --pred rollout.mp4 --masks motion --per-frame --format csv
  wm-metrics seg --ref real/ --pred rollout/ --masks depth --depth real_depth/ \
      --intrinsics 154.5,154.5,63.5,63.5 --config configs/segmentation/tabletop.yaml

Definitions, algorithms, parameters and measured accuracy: docs/metrics-segmentation.md.
Exit codes: 0 success, 1 bad input (the message names the file and what was expected), other
non-zero: usage error.)";

struct SegCommandOptions {
  std::string ref, pred, masks, mask_dir, labels, config, depth, intrinsics, save_masks;
  std::string format = "json";
  bool per_frame = false;

  // Flags each mask source needs, checked before any frame is read.
  void Check() const {
    const bool files = masks == "files", depth_source = masks == "depth";
    wm::Check(!files || !mask_dir.empty(), "--masks files needs --mask-dir (label images)",
              {.key = "--mask-dir"});
    wm::Check(!files || !labels.empty() || !config.empty(),
              "--masks files needs a label map: --labels 0=background,1=arm,... or --config",
              {.key = "--labels"});
    wm::Check(!depth_source || !depth.empty(), "--masks depth needs --depth (depth images)",
              {.key = "--depth"});
    wm::Check(files || mask_dir.empty(), "--mask-dir is only for --masks files",
              {.key = "--mask-dir"});
    wm::Check(depth_source || (depth.empty() && intrinsics.empty()),
              "--depth and --intrinsics are only for --masks depth", {.key = "--depth"});
  }
};

// Frames of `path`, errors prefixed with what they were meant to be.
Frames LoadNamed(const std::string& path, const std::string& what) {
  try {
    return LoadFrames(path);
  } catch (const Error& e) {
    throw Error(what + ": " + e.message(), e.context());
  }
}

std::unique_ptr<seg::MaskSource> MakeSource(const SegCommandOptions& o) {
  seg::SegConfig config;
  if (!o.config.empty()) config = seg::LoadSegConfig(o.config);
  if (o.masks == "files") {
    seg::LabelMap labels = o.labels.empty() ? config.labels : seg::ParseLabelList(o.labels);
    if (o.labels.empty()) {
      wm::Check(!labels.regions.empty(), "the config has no `labels` for --masks files",
                {.file = o.config, .key = "labels"});
    } else {
      labels.unlisted = config.labels.unlisted;
    }
    return seg::MakeFileMaskSource(LoadNamed(o.mask_dir, "label images (--mask-dir)"),
                                   std::move(labels));
  }
  if (o.masks == "motion") return seg::MakeMotionMaskSource(config.motion);
  if (!o.intrinsics.empty()) config.depth.intrinsics = seg::CameraIntrinsics::Parse(o.intrinsics);
  config.depth.Check();  // missing intrinsics fail here, before the depth frames are read
  return seg::MakeDepthMaskSource(LoadNamed(o.depth, "depth images (--depth)"), config.depth);
}

void SaveMasks(const std::string& dir, const std::vector<seg::RegionMap>& maps) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  wm::Check(!ec, "cannot create the folder: " + ec.message(), {.file = dir});
  for (size_t t = 0; t < maps.size(); ++t) {
    char name[32];
    std::snprintf(name, sizeof(name), "%06zu.png", t);
    seg::WriteRegionMapPng((std::filesystem::path(dir) / name).string(), maps[t]);
  }
}

std::string CsvCell(const nlohmann::json& v) {
  if (v.is_null()) return "";
  if (!v.is_string()) return v.dump();
  std::string s = v.get<std::string>();
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string quoted = "\"";
  for (char c : s) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

std::string FormatSegCsv(const nlohmann::json& result) {
  std::vector<std::string> columns = {"mse"};
  for (seg::Region r : seg::kRegions) columns.push_back("mse_" + seg::RegionName(r));
  for (seg::Region r : seg::kRegions) columns.push_back("pixels_" + seg::RegionName(r));
  std::string out = "frame";
  for (const std::string& c : columns) out += "," + c;
  out += "\n";
  auto row = [&](const std::string& frame, const nlohmann::json& values) {
    out += CsvCell(frame);
    for (const std::string& c : columns) out += "," + CsvCell(values.value(c, nlohmann::json()));
    out += "\n";
  };
  for (const auto& f : result.value("per_frame", nlohmann::json::array())) row(f.at("frame"), f);
  row("mean", result);
  return out;
}

void Run(const SegCommandOptions& o) {
  o.Check();
  std::unique_ptr<seg::MaskSource> source = MakeSource(o);
  const Frames ref = LoadNamed(o.ref, "reference frames (--ref)");
  const Frames pred = LoadNamed(o.pred, "predicted frames (--pred)");
  CheckPaired(ref, pred);
  const std::vector<seg::RegionMap> maps = source->Masks(ref);
  if (!o.save_masks.empty()) SaveMasks(o.save_masks, maps);
  const seg::SegmentedMse result = seg::VideoMse(ref.images, pred.images, maps);
  nlohmann::json json = seg::ToJson(result, o.per_frame ? &ref.sources : nullptr);
  json["masks"] = source->name();
  std::cout << (o.format == "json" ? json.dump(2) + "\n" : FormatSegCsv(json));
}

}  // namespace

void AddSegCommand(CLI::App& app) {
  auto o = std::make_shared<SegCommandOptions>();
  CLI::App* cmd = app.add_subcommand("seg", kSegCommandSummary);
  cmd->footer(kFooter);
  cmd->add_option("--ref", o->ref, "Reference (ground truth): folder of frames or video")
      ->required();
  cmd->add_option("--pred", o->pred, "Prediction: folder of frames or video")->required();
  cmd->add_option("--masks", o->masks, "Region maps from: files, motion or depth")
      ->required()
      ->check(CLI::IsMember({"files", "motion", "depth"}));
  cmd->add_option("--mask-dir", o->mask_dir, "files: label images, one per reference frame");
  cmd->add_option("--labels", o->labels, "files: label map, e.g. 0=background,1=arm,2=object");
  cmd->add_option("--config", o->config, "Segmentation config YAML (configs/segmentation/)");
  cmd->add_option("--depth", o->depth, "depth: depth images, one per reference frame");
  cmd->add_option("--intrinsics", o->intrinsics, "depth: camera fx,fy,cx,cy in pixels");
  cmd->add_option("--save-masks", o->save_masks, "Write the region maps as PNGs to this folder");
  cmd->add_flag("--per-frame", o->per_frame, "Also print every frame's values");
  cmd->add_option("--format", o->format, "json or csv")
      ->check(CLI::IsMember({"json", "csv"}))
      ->capture_default_str();
  cmd->callback([o] { Run(*o); });
}

}  // namespace wm::metrics

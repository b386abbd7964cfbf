#include "evaluate/region_masks.h"

#include <cmath>

#include "core/error.h"
#include "metrics/image_io.h"
#include "metrics/segmentation/segmented_mse.h"

namespace wm::evaluate {
namespace seg = metrics::seg;
namespace {

// Every frame of one image stream, decoded at its own resolution.
metrics::Frames StreamFrames(const Episode& episode, const std::string& key,
                             const std::string& where) {
  auto it = episode.images.find(key);
  Check(it != episode.images.end(),
        "the mask source needs the image stream '" + key + "', which this episode lacks",
        {.file = where});
  metrics::Frames frames;
  for (size_t t = 0; t < it->second.frames.size(); ++t) {
    frames.sources.push_back(where + "/" + key + "[" + std::to_string(t) + "]");
    frames.images.push_back(metrics::DecodeImage(it->second.frames[t], frames.sources.back()));
  }
  return frames;
}

seg::RegionMap ResizeNearest(const seg::RegionMap& map, int size) {
  seg::RegionMap out(size, size);
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      // Sample the source pixel under the output pixel's centre (OpenCV's INTER_NEAREST_EXACT).
      const int sy = static_cast<int>((y + 0.5) * map.height / size);
      const int sx = static_cast<int>((x + 0.5) * map.width / size);
      out.at(y, x) = map.at(sy, sx);
    }
  }
  return out;
}

}  // namespace

RegionMasks::RegionMasks(const MaskOptions& options) : options_(options) {
  const std::string& s = options.source;
  Check(s == "none" || s == "files" || s == "motion" || s == "depth",
        "unknown mask source '" + s + "' (expected none, files, motion or depth)",
        {.key = "--masks"});
  if (!enabled()) return;
  if (!options.seg_config.empty()) config_ = seg::LoadSegConfig(options.seg_config);
  if (s == "files") {
    Check(!config_.labels.regions.empty(),
          "--masks files needs --seg-config with a `labels` map (label value -> region)",
          {.file = options.seg_config, .key = "labels"});
  }
  if (s == "depth") {
    if (!options.intrinsics.empty()) {
      config_.depth.intrinsics = seg::CameraIntrinsics::Parse(options.intrinsics);
    }
    config_.depth.Check();
  }
}

std::vector<seg::RegionMap> RegionMasks::Maps(const Episode& episode, const std::string& image_key,
                                              int64_t first, int64_t count, int size,
                                              const std::string& where) const {
  const metrics::Frames rgb = StreamFrames(episode, image_key, where);
  std::unique_ptr<seg::MaskSource> source;
  if (options_.source == "files") {
    source =
        seg::MakeFileMaskSource(StreamFrames(episode, options_.labels_key, where), config_.labels);
  } else if (options_.source == "motion") {
    source = seg::MakeMotionMaskSource(config_.motion);
  } else {
    source =
        seg::MakeDepthMaskSource(StreamFrames(episode, options_.depth_key, where), config_.depth);
  }
  const std::vector<seg::RegionMap> full = source->Masks(rgb);
  Check(first >= 0 && first + count <= static_cast<int64_t>(full.size()),
        "the episode has fewer frames than the rollout scores", {.file = where});
  std::vector<seg::RegionMap> out;
  for (int64_t t = first; t < first + count; ++t) out.push_back(ResizeNearest(full[t], size));
  return out;
}

std::map<std::string, std::vector<double>> ScoreRegions(const Clip& real, const Clip& pred,
                                                        const std::vector<seg::RegionMap>& maps) {
  Check(real.frames == pred.frames && real.frames == static_cast<int64_t>(maps.size()),
        "one region map per scored frame expected");
  std::map<std::string, std::vector<double>> out;
  for (int64_t t = 0; t < real.frames; ++t) {
    const seg::FrameSegmentedMse m =
        seg::FrameMse(FrameImage(real, t), FrameImage(pred, t), maps[t]);
    for (seg::Region region : seg::kRegions) {
      const auto& r = m.regions[seg::RegionSlot(region)];
      out["mse_" + seg::RegionName(region)].push_back(r.mse ? *r.mse : NAN);
    }
  }
  return out;
}

}  // namespace wm::evaluate

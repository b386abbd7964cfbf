// wm-ingest: raw robot episodes (RLDS / HDF5 / image folders / LeRobot) -> a checksummed shard
// dataset.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>

#include "core/cli_parse.h"
#include "core/error.h"
#include "core/log.h"
#include "core/provenance.h"
#include "ingest/ingest_options.h"
#include "ingest/suggest_mapping.h"

namespace {

constexpr const char* kFooter = R"(
Example:
  wm-ingest --format rlds --input data/raw/wm_tabletop/1.0.0 --split train --output data/shards/train
  wm-ingest --format rlds --input D --output OUT/part-3 --shard-index 3 --num-shards 8  # Slurm array
  wm-shard merge --output OUT/all OUT/part-*
  wm-ingest --format lerobot --input ../shared/samples/lerobot/unitree_g1_v21 --output data/g1
  wm-ingest --format lerobot --input DIR --suggest-mapping > configs/lerobot/DIR_NAME.yaml

A killed run resumes when started again with the same options; the output appears complete or
not at all (index.json is written last). Formats: docs/shard-format.md, docs/folder-format.md,
docs/hdf5-layout.md, docs/dataset-mapping.md, docs/lerobot-mapping.md, docs/parquet.md.
Exit codes: 0 success, 1 bad input or I/O error (message names file, record and key), 2 usage.)";

bool ParseSize(const std::string& s, int& w, int& h) {
  return std::sscanf(s.c_str(), "%dx%d", &w, &h) == 2 && w > 0 && h > 0;
}

}  // namespace

int main(int argc, char** argv) {
  wm::ingest::IngestOptions o;
  std::string resize, log_level = "info";
  bool header_only = false;
  CLI::App app{"wm-ingest: convert robot episodes into wmkit shard datasets"};
  app.footer(kFooter);
  app.set_version_flag("--version", wm::VersionString("wm-ingest"));
  app.add_option("--format", o.format, "Input format")
      ->required()
      ->check(CLI::IsMember({"rlds", "hdf5", "folder", "lerobot"}));
  app.add_option("--input", o.input,
                 "RLDS dataset dir (<name>/<version>), HDF5 file/dir, episode folder root, or "
                 "LeRobot dataset dir (holding meta/info.json)")
      ->required();
  app.add_option("--output", o.output,
                 "Dataset directory to write (required unless --suggest-mapping)");
  bool suggest = false;
  app.add_flag("--suggest-mapping", suggest,
               "RLDS / LeRobot: print a guessed mapping YAML (from features.json / info.json) "
               "and exit; comments mark the uncertain guesses");
  app.add_option("--dataset", o.dataset,
                 "Dataset name recorded in index.json (default: the source's)");
  app.add_option("--split", o.split, "Split to read (RLDS) and record")->capture_default_str();
  app.add_option("--mapping", o.mapping,
                 "RLDS feature mapping YAML (default: configs/datasets/<name>.yaml); LeRobot "
                 "mapping (default: configs/lerobot/<dir name>.yaml, else default.yaml)");
  app.add_option("--configs", o.configs_dir,
                 "Configs directory (default: $WMKIT_CONFIGS or the repo's configs/)");
  app.add_option(
      "--camera", o.camera,
      "HDF5: camera key under obs/ (default: first RGB camera); LeRobot: video "
      "feature, e.g. observation.images.top (default: the mapping's, else the only one)");
  bool no_depth = false;
  app.add_flag("--hdf5-no-depth", no_depth, "HDF5: ignore obs/<camera>_depth (e.g. float depth)");
  app.add_option("--action-space", o.action_space,
                 "HDF5 / folder: the actions' space, eef_delta (7 wide), joint_position or other "
                 "(default: eef_delta when 7 wide, else other)")
      ->check(CLI::IsMember({"eef_delta", "joint_position", "other"}));
  app.add_option("--hdf5-memory-limit-mb", o.hdf5_limits.memory_mb,
                 "HDF5: memory a file listing or demo read may use (0: no limit)")
      ->capture_default_str();
  app.add_option("--hdf5-cpu-limit-s", o.hdf5_limits.cpu_seconds,
                 "HDF5: CPU seconds a file listing or demo read may use (0: no limit)")
      ->capture_default_str();
  app.add_option("--resize", resize, "Re-encode every frame at WxH (default: keep encoded bytes)");
  app.add_option("--shard-size-mb", o.shard_size_mb, "Close a shard at this size")
      ->capture_default_str();
  app.add_option("--shard-index", o.shard_index, "This job's index (Slurm: $SLURM_ARRAY_TASK_ID)")
      ->capture_default_str();
  app.add_option("--num-shards", o.num_shards, "Number of jobs splitting the input")
      ->capture_default_str();
  app.add_option("--max-episodes", o.max_episodes, "Only the first N input episodes (-1: all)")
      ->capture_default_str();
  app.add_option("--on-error", o.on_error, "fail: stop at a bad episode; skip: skip and count it")
      ->capture_default_str()
      ->check(CLI::IsMember({"fail", "skip"}));
  app.add_option("--threads", o.threads, "Decode/check threads")->capture_default_str();
  app.add_flag("--header-check-only", header_only,
               "Decode only each stream's first frame (faster, pass-through)");
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error")
      ->capture_default_str();
  if (const int rc = wm::ParseCommandLine(app, argc, argv); rc >= 0) return rc;
  wm::InitLogging(log_level);
  if (!suggest && o.output.empty()) {
    std::cerr << "wm-ingest: --output is required\n";
    return 2;
  }
  try {
    if (suggest) {
      std::cout << wm::ingest::SuggestMapping(o.format, o.input);
      return 0;
    }
    if (!resize.empty() && !ParseSize(resize, o.resize_width, o.resize_height)) {
      throw wm::Error("--resize must look like 128x128, got '" + resize + "'");
    }
    o.full_image_check = !header_only;
    o.hdf5_depth = !no_depth;
    wm::ingest::IngestSummary s = wm::ingest::RunIngest(o);
    if (!s.already_complete) {
      spdlog::info("wrote {} episodes, {} steps, {:.1f} MB in {:.1f} s ({} skipped) -> {}",
                   s.episodes, s.steps, s.bytes / 1048576.0, s.seconds, s.skipped, o.output);
    }
  } catch (const std::exception& e) {
    std::cerr << "wm-ingest: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

#pragma once
// Options of one `wm-ingest` run. Everything that shapes the output goes into ToConfig() and so
// into the config hash that resume and provenance rely on.
#include <nlohmann/json.hpp>
#include <string>

#include "ingest/hdf5/hdf5_source.h"

namespace wm::ingest {

struct IngestOptions {
  std::string format;           // "rlds", "hdf5", "folder" or "lerobot"
  std::string input;            // dataset directory / file / folder
  std::string output;           // dataset directory to write
  std::string dataset;          // name recorded in index.json; default: the source's own name
  std::string split = "train";  // RLDS split to read; recorded in index.json for every format
  // RLDS: mapping YAML (default configs/datasets/<name>.yaml); LeRobot: configs/lerobot/
  // <dataset dir name>.yaml, else configs/lerobot/default.yaml
  std::string mapping;
  std::string configs_dir;  // where configs/datasets lives (default: wm::DefaultConfigsDir)
  // HDF5: obs/<camera> key (default: first RGB camera found); LeRobot: video feature key
  // (default: the mapping's, else the only video feature)
  std::string camera;
  bool hdf5_depth = true;  // HDF5: also read obs/<camera>_depth (uint16) when present
  // HDF5 / folders: the actions' space (eef_delta, joint_position, other); empty: eef_delta when
  // 7 wide, else other (ingest::SetActions). LeRobot's mapping names its own; RLDS's are 7 wide.
  std::string action_space;
  // HDF5: limits of the child process that reads each file listing / demo (hdf5_source.h); they
  // do not shape the output, so they stay out of ToConfig().
  ChildLimits hdf5_limits = kDefaultHdf5ReadLimits;
  int resize_width = 0, resize_height = 0;  // 0: keep encoded bytes as they are
  double shard_size_mb = 256;               // a shard closes once it reaches this size
  int shard_index = 0, num_shards = 1;      // this job's contiguous block of the input episodes
  int64_t max_episodes = -1;                // first N input episodes only (-1: all)
  std::string on_error = "fail";            // "fail" or "skip" a bad episode
  int threads = 2;                          // decode/check workers
  bool full_image_check = true;             // decode every frame (false: first frame + magic only)
  int zstd_level = 3;

  // Throws wm::Error describing the first invalid option.
  void Check() const;
  nlohmann::json ToConfig() const;
};

struct IngestSummary {
  uint64_t episodes = 0, steps = 0, bytes = 0, skipped = 0, resumed_from = 0;
  double seconds = 0;
  bool already_complete = false;
};

IngestSummary RunIngest(const IngestOptions& options);

}  // namespace wm::ingest

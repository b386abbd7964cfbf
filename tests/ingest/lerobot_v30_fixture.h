#pragma once
// Builds a LeRobotDataset v3.0 directory from a v2.1 one, as LeRobot's
// convert_dataset_v21_to_v30.py lays it out, for tests (docs/lerobot-mapping.md, "v3.0 test
// fixtures"). Data rows are copied value for value with the test Parquet writer (PLAIN,
// uncompressed, one row group per episode); videos are remuxed, not re-encoded (packets copied,
// timestamps shifted), so every frame decodes to the same pixels as in the v2.1 files.
#include <cstdint>
#include <string>
#include <vector>

namespace wm::ingest::testing {

struct V30FixtureOptions {
  // Episode indices per data file (data/chunk-000/file-000.parquet, file-001, ...) and per
  // video file of each camera; every episode must be in exactly one of each.
  std::vector<std::vector<int64_t>> data_files = {{1, 2}, {4}};
  std::vector<std::vector<int64_t>> video_files = {{1, 2, 4}};
  // Damage for the error tests: added to the last episode's videos/<key>/to_timestamp, and an
  // episode whose meta/episodes row names the wrong data file (-1: none).
  double extra_to_timestamp_s = 0;
  int64_t misplaced_episode = -1;
};

// Writes `out_dir` (created; replaced if it exists) from the v2.1 dataset at `v21_root`.
void WriteV30Fixture(const std::string& v21_root, const std::string& out_dir,
                     const V30FixtureOptions& options = {});

// Concatenates MP4 files by copying their packets, each file's timestamps shifted to start where
// the previous one ended. Returns each input's [from, to) in seconds of the output.
std::vector<std::pair<double, double>> ConcatenateVideos(const std::vector<std::string>& inputs,
                                                         const std::string& output);

}  // namespace wm::ingest::testing

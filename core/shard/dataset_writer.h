#pragma once
// Writes a dataset directory: rolls shards at a size bound, commits each shard atomically,
// records progress in `.wm-ingest-state.json` after every shard so a killed run resumes where
// the last finished shard ends, and writes index.json last.
#include <memory>
#include <optional>
#include <string>

#include "core/shard/dataset_index.h"
#include "core/shard/shard_writer.h"

namespace wm::shard {

struct DatasetWriterOptions {
  std::string dir;                           // created if missing
  uint64_t shard_size_bytes = 256ull << 20;  // a shard is closed once it reaches this size
  int zstd_level = 3;
  std::string config_hash;  // a resume only continues the same config
};

class DatasetWriter {
 public:
  explicit DatasetWriter(DatasetWriterOptions options);
  ~DatasetWriter();

  // Input episodes (written or skipped) already covered by finished shards of an earlier run.
  uint64_t resume_position() const { return consumed_; }
  size_t resumed_shards() const { return resumed_shards_; }

  // `position` is the input ordinal of this episode; calls come in increasing order.
  void Add(const Episode& episode, uint64_t position);
  void Skip(const SkippedEpisode& skipped, uint64_t position);

  // Closes the last shard, computes action statistics from the shards, writes index.json,
  // removes the resume state. Fields of `index` other than shards/totals/stats/skipped/features
  // (dataset, split, source, provenance) come from the caller.
  DatasetIndex Finish(DatasetIndex index);

  static constexpr const char* kStateFileName = ".wm-ingest-state.json";

 private:
  void CloseShard();
  void SaveState() const;
  std::string PathOf(const std::string& name) const;

  DatasetWriterOptions options_;
  std::unique_ptr<ShardWriter> current_;
  std::string current_name_;
  std::vector<ShardInfo> shards_;
  std::vector<SkippedEpisode> skipped_, pending_skipped_;
  nlohmann::json features_;
  uint64_t consumed_ = 0, next_position_ = 0;
  size_t resumed_shards_ = 0;
};

}  // namespace wm::shard

#pragma once
// Writes one shard file: header, episode records, footer index, trailer (docs/shard-format.md).
// The file appears under its final name only on Finish(); until then it is a hidden temp file.
#include <memory>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "core/episode.h"
#include "core/shard/shard_format.h"

namespace wm::shard {

class ShardWriter {
 public:
  explicit ShardWriter(const std::string& path, int zstd_level = 3);
  void Append(const Episode& episode);
  uint64_t bytes() const { return file_.bytes_written(); }
  size_t num_episodes() const { return entries_.size(); }
  uint64_t num_steps() const { return steps_; }
  void Finish();  // writes footer + trailer, fsyncs and renames into place

 private:
  AtomicFileWriter file_;
  int zstd_level_;
  std::vector<IndexEntry> entries_;
  uint64_t steps_ = 0;
};

}  // namespace wm::shard

#pragma once
// Random access to the episodes of a dataset directory by global index (0..num_episodes-1),
// across shards, with every record checked on read.
#include <memory>
#include <string>
#include <vector>

#include "core/shard/dataset_index.h"
#include "core/shard/shard_reader.h"

namespace wm::shard {

class DatasetReader {
 public:
  explicit DatasetReader(const std::string& dir);
  const DatasetIndex& index() const { return index_; }
  const std::string& dir() const { return dir_; }
  size_t num_episodes() const { return index_.num_episodes; }

  Episode ReadEpisode(size_t k) const;
  // (shard number, episode within shard) of global episode k.
  std::pair<size_t, size_t> Locate(size_t k) const;
  const ShardReader& shard(size_t i) const { return *shards_[i]; }

 private:
  std::string dir_;
  DatasetIndex index_;
  std::vector<std::unique_ptr<ShardReader>> shards_;
  std::vector<uint64_t> first_episode_;  // prefix sums of num_episodes
};

struct VerifyReport {
  uint64_t episodes = 0, steps = 0, bytes = 0;
};
// Re-checks everything: shard sizes and SHA-256 against index.json, every header, footer,
// record CRC and section, and the totals. Throws wm::Error at the first problem.
VerifyReport VerifyDataset(const std::string& dir);

}  // namespace wm::shard

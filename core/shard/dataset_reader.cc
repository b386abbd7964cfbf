#include "core/shard/dataset_reader.h"

#include <algorithm>
#include <filesystem>

#include "core/error.h"
#include "core/sha256.h"

namespace wm::shard {
namespace fs = std::filesystem;

DatasetReader::DatasetReader(const std::string& dir) : dir_(dir), index_(ReadIndex(dir)) {
  uint64_t first = 0;
  for (const auto& s : index_.shards) {
    std::string path = (fs::path(dir) / s.file).string();
    shards_.push_back(std::make_unique<ShardReader>(path));
    Check(shards_.back()->num_episodes() == s.num_episodes,
          "shard holds " + std::to_string(shards_.back()->num_episodes()) +
              " episodes but index.json says " + std::to_string(s.num_episodes),
          {.file = path});
    first_episode_.push_back(first);
    first += s.num_episodes;
  }
}

std::pair<size_t, size_t> DatasetReader::Locate(size_t k) const {
  Check(k < index_.num_episodes,
        "episode " + std::to_string(k) + " out of range (dataset has " +
            std::to_string(index_.num_episodes) + ")",
        {.file = dir_});
  auto it = std::upper_bound(first_episode_.begin(), first_episode_.end(), k);
  size_t shard = static_cast<size_t>(it - first_episode_.begin()) - 1;
  return {shard, k - first_episode_[shard]};
}

Episode DatasetReader::ReadEpisode(size_t k) const {
  auto [shard, local] = Locate(k);
  return shards_[shard]->ReadEpisode(local);
}

VerifyReport VerifyDataset(const std::string& dir) {
  DatasetIndex index = ReadIndex(dir);
  VerifyReport report;
  for (const auto& s : index.shards) {
    std::string path = (fs::path(dir) / s.file).string();
    Check(fs::exists(path), "shard listed in index.json is missing", {.file = path});
    uint64_t bytes = fs::file_size(path);
    Check(bytes == s.bytes,
          "size " + std::to_string(bytes) + " differs from index.json's " + std::to_string(s.bytes),
          {.file = path});
    Check(Sha256File(path) == s.sha256, "SHA-256 differs from index.json's (corrupt shard)",
          {.file = path});
    ShardReader reader(path);
    uint64_t steps = 0;
    for (size_t k = 0; k < reader.num_episodes(); ++k) {
      Episode e = reader.ReadEpisode(k);
      Check(static_cast<uint64_t>(e.num_steps) == reader.entries()[k].num_steps,
            "num_steps disagrees with the footer index", {.file = path, .record = int64_t(k)});
      steps += static_cast<uint64_t>(e.num_steps);
    }
    Check(reader.num_episodes() == s.num_episodes && steps == s.num_steps,
          "episode/step counts differ from index.json", {.file = path});
    report.episodes += s.num_episodes;
    report.steps += steps;
    report.bytes += bytes;
  }
  return report;
}

}  // namespace wm::shard

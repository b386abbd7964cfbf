#include "core/shard/dataset_writer.h"

#include <spdlog/spdlog.h>

#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/json_int.h"
#include "core/sha256.h"
#include "core/shard/shard_reader.h"

namespace wm::shard {
namespace fs = std::filesystem;
using nlohmann::json;

DatasetWriter::DatasetWriter(DatasetWriterOptions options) : options_(std::move(options)) {
  fs::create_directories(options_.dir);
  const std::string state_path = PathOf(kStateFileName);
  if (!fs::exists(state_path)) return;
  json state = json::parse(ReadFile(state_path), nullptr, false);
  if (state.is_discarded() || state.value("config_hash", "") != options_.config_hash) {
    spdlog::warn("{}: resume state is from another config; starting over", state_path);
    return;
  }
  // Trust a finished shard only if it is intact and the one the state recorded.
  for (const auto& s : state.at("shards")) {
    ShardInfo info{s.at("file"), s.at("bytes"), s.at("sha256"), s.at("num_episodes"),
                   s.at("num_steps")};
    std::string path = PathOf(info.file);
    if (!fs::exists(path) || fs::file_size(path) != info.bytes || Sha256File(path) != info.sha256) {
      spdlog::warn("{}: missing or changed since the interrupted run; starting over", path);
      shards_.clear();
      return;
    }
    shards_.push_back(info);
  }
  for (const auto& s : state.at("skipped"))
    skipped_.push_back({s.at("file"), s.at("record"), s.at("reason")});
  features_ = state.at("features");
  consumed_ = next_position_ = JsonInt<uint64_t>(state.at("consumed"));
  resumed_shards_ = shards_.size();
}

DatasetWriter::~DatasetWriter() = default;

std::string DatasetWriter::PathOf(const std::string& name) const {
  return (fs::path(options_.dir) / name).string();
}

void DatasetWriter::Add(const Episode& episode, uint64_t position) {
  json features = FeaturesOf(episode);
  if (features_.is_null()) {
    features_ = features;
  } else if (features != features_) {
    throw Error("episode streams differ from the dataset's first episode: expected " +
                    features_.dump() + ", got " + features.dump(),
                {.file = episode.source_file, .record = episode.source_record});
  }
  if (!current_) {
    current_name_ = ShardFileName(static_cast<int>(shards_.size()));
    current_ = std::make_unique<ShardWriter>(PathOf(current_name_), options_.zstd_level);
  }
  current_->Append(episode);
  next_position_ = position + 1;
  if (current_->bytes() >= options_.shard_size_bytes) CloseShard();
}

void DatasetWriter::Skip(const SkippedEpisode& skipped, uint64_t position) {
  pending_skipped_.push_back(skipped);
  next_position_ = position + 1;
}

void DatasetWriter::CloseShard() {
  if (!current_) return;
  current_->Finish();
  std::string path = PathOf(current_name_);
  shards_.push_back({current_name_, fs::file_size(path), Sha256File(path), current_->num_episodes(),
                     current_->num_steps()});
  current_.reset();
  skipped_.insert(skipped_.end(), pending_skipped_.begin(), pending_skipped_.end());
  pending_skipped_.clear();
  consumed_ = next_position_;
  SaveState();
}

void DatasetWriter::SaveState() const {
  json shards = json::array(), skipped = json::array();
  for (const auto& s : shards_) {
    shards.push_back({{"file", s.file},
                      {"bytes", s.bytes},
                      {"sha256", s.sha256},
                      {"num_episodes", s.num_episodes},
                      {"num_steps", s.num_steps}});
  }
  for (const auto& s : skipped_) {
    skipped.push_back({{"file", s.file}, {"record", s.record}, {"reason", s.reason}});
  }
  json state = {{"config_hash", options_.config_hash},
                {"consumed", consumed_},
                {"shards", shards},
                {"skipped", skipped},
                {"features", features_}};
  WriteFileAtomically(PathOf(kStateFileName), state.dump(2));
}

DatasetIndex DatasetWriter::Finish(DatasetIndex index) {
  CloseShard();
  skipped_.insert(skipped_.end(), pending_skipped_.begin(), pending_skipped_.end());
  pending_skipped_.clear();
  Check(!shards_.empty(), "no episodes were written (all input episodes skipped or none found)",
        {.file = options_.dir});
  std::vector<float> actions;
  index.num_episodes = index.num_steps = 0;
  for (const auto& s : shards_) {
    ShardReader(PathOf(s.file)).AppendActions(actions);
    index.num_episodes += s.num_episodes;
    index.num_steps += s.num_steps;
  }
  index.shards = shards_;
  // Damage found while listing inputs (from the caller) comes before per-episode skips.
  index.skipped.insert(index.skipped.end(), skipped_.begin(), skipped_.end());
  index.features = features_;
  index.action_stats = ComputeActionStats(actions, ActionDimOf(features_));
  WriteIndex(options_.dir, index);
  fs::remove(PathOf(kStateFileName));
  return index;
}

}  // namespace wm::shard

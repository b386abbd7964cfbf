#pragma once
// index.json of a shard dataset directory: what it holds, where, with which hashes and action
// statistics. Schema: schemas/shard-index.schema.json; prose: docs/shard-format.md.
#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/episode.h"

namespace wm::shard {

struct ShardInfo {
  std::string file;  // name inside the dataset directory
  uint64_t bytes = 0;
  std::string sha256;
  uint64_t num_episodes = 0, num_steps = 0;
};

struct SkippedEpisode {
  std::string file;
  int64_t record = 0;
  std::string reason;
};

// Per action dimension, over every step of every episode; computed in float64.
struct ActionStats {
  using Vec = std::vector<double>;  // features.action.dim entries (default: 7 zeros)
  Vec mean = Vec(kActionDim), std = Vec(kActionDim), min = Vec(kActionDim), max = Vec(kActionDim),
      q01 = Vec(kActionDim), q99 = Vec(kActionDim);
};

struct DatasetIndex {
  std::string dataset, split;
  nlohmann::json source = nlohmann::json::object();    // {"format", "inputs": [...]}
  nlohmann::json features = nlohmann::json::object();  // action + image streams
  std::vector<ShardInfo> shards;
  uint64_t num_episodes = 0, num_steps = 0;
  ActionStats action_stats;
  std::vector<SkippedEpisode> skipped;
  nlohmann::json provenance = nlohmann::json::object();
};

// {"mean", "std", "min", "max", "q01", "q99"}, each a D-vector; FromJson throws json errors.
nlohmann::json StatsToJson(const ActionStats& stats);
ActionStats StatsFromJson(const nlohmann::json& j);

nlohmann::json IndexToJson(const DatasetIndex& index);
// Validates structure and version; errors name `file` and the offending key.
DatasetIndex IndexFromJson(const nlohmann::json& j, const std::string& file);

DatasetIndex ReadIndex(const std::string& dir);
void WriteIndex(const std::string& dir, const DatasetIndex& index);  // atomic

// `actions` is [N, dim] row-major. Quantiles interpolate linearly (numpy's default).
ActionStats ComputeActionStats(const std::vector<float>& actions, int64_t dim = kActionDim);
// features.action.dim (7 for indexes that predate other widths).
int64_t ActionDimOf(const nlohmann::json& features);
// features.action.space: "eef_delta", "joint_position" or "other" ("eef_delta" for indexes that
// predate other widths, whose action is the canonical one).
std::string ActionSpaceOf(const nlohmann::json& features);
// Whether the dataset's action is the canonical 7-dim eef_delta one (index.json version 1).
bool IsCanonicalAction(const nlohmann::json& features);
// Whether (dim, space) is the canonical 7-dim eef_delta action.
bool IsCanonicalAction(int64_t dim, const std::string& space);
// Whether `space` is one of the action spaces a dataset may declare.
bool IsKnownActionSpace(const std::string& space);

// The `features` block describing an episode's streams (action layout, image shapes).
nlohmann::json FeaturesOf(const Episode& episode);

}  // namespace wm::shard

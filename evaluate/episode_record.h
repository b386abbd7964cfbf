#pragma once
// Everything wm-eval keeps of one scored episode, so that the report can be assembled from the
// episodes of several shard jobs exactly as from one run, and the part files that carry them
// between jobs (docs/reports.md, "Sharded evaluation"; schemas/eval-part.schema.json).
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace wm::evaluate {

struct EpisodeRecord {
  int64_t episode = 0;  // index in the token dataset
  std::string policy_id;
  int64_t steps = 0;  // imagined frames
  // kind (copy_last, tokenizer_recon, plain, retrace) -> metric -> one value per step
  std::map<std::string, std::map<std::string, std::vector<double>>> scores;
  std::map<std::string, std::vector<double>> clip_descriptors;  // kind (also "real") -> features
  std::map<std::string, double> model_return;                   // rollout -> imagined return
  double real_return = 0;
  // rollout -> per step: disagreement between samples and the first sample's MSE (samples >= 2)
  std::map<std::string, std::vector<double>> spread, sample_mse;
  // rollout -> one row per (step, context slot) of sample 0: step, slot, frame, action[7]
  std::map<std::string, std::vector<std::vector<double>>> contexts;
};

// One shard job's episodes of one checkpoint. `identity` holds what must agree between the parts
// of one report (eval config hash, checkpoint, tokenizer and data hashes, num_shards).
struct EvalPart {
  nlohmann::json identity;
  int shard_index = 0;
  std::vector<EpisodeRecord> records;
};

// JSON (NaN and infinities as strings, finite numbers round-trip exactly); the records'
// SHA-256 is stored beside them and checked on read. Written atomically.
void WriteEvalPart(const std::string& path, const EvalPart& part);
// Throws wm::Error naming `path` when it is unreadable, truncated or its checksum differs.
EvalPart ReadEvalPart(const std::string& path);

// REPORT_DIR/<name>/parts/part-<index>-of-<count>.json
std::string PartPath(const std::string& dir, int index, int count);

// Every part's records in episode order once all `num_shards` parts exist; empty otherwise.
// Parts of another `identity`, and overlapping or missing episodes, are errors naming the file.
std::optional<std::vector<EpisodeRecord>> GatherParts(const std::string& dir,
                                                      const nlohmann::json& identity,
                                                      const std::vector<int64_t>& episodes,
                                                      int num_shards);

}  // namespace wm::evaluate

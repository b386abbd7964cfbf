#pragma once
// manifest.json of a checkpoint's report: what was evaluated, on what, with which settings.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "evaluate/evaluator.h"

namespace wm::shard {
class DatasetReader;
}
namespace wm::tokens {
class TokenDataset;
}
namespace wm::tokenize {
class Tokenizer;
}
namespace wm::train {
class DynamicsModel;
}

namespace wm::evaluate {

// What a report's manifest says of the evaluated checkpoint besides its name and path; each kind
// of model fills it (DescribeDynamicsCheckpoint; the motion model in motion_imagination.cc).
struct CheckpointInfo {
  std::string file;  // the checkpoint.wmt evaluated: its SHA-256 names it everywhere
  int64_t step = 0;  // training step
  // More manifest "checkpoint" keys: policy_conditioning for a token dynamics model;
  // model_kind "motion", config and config_hash for a motion one.
  nlohmann::json extra;
};
CheckpointInfo DescribeDynamicsCheckpoint(const train::DynamicsModel& model);

// Throws wm::Error naming the file unless the token dataset was written by `tok` from exactly
// the shards of `shards`: the three inputs must describe the same episodes.
void CheckInputsBelongTogether(const tokens::TokenDataset& tokens, const tokenize::Tokenizer& tok,
                               const shard::DatasetReader& shards);

// The report name of checkpoint `c`: --name's entry, else the run directory's name.
std::string ReportName(const EvalOptions& options, size_t c);

// The eval settings that shape the numbers (hashed into config_hash).
nlohmann::json EvalConfigJson(const EvalOptions& options);

// `checkpoint`: the path given for this report's checkpoint (a run directory or a file).
void WriteEvalManifest(const std::string& dir, const std::string& name,
                       const std::string& checkpoint, const EvalOptions& o,
                       const CheckpointInfo& info, const tokenize::Tokenizer& tok,
                       const tokens::TokenDataset& data, const shard::DatasetReader& shards);

}  // namespace wm::evaluate

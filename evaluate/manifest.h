#pragma once
// manifest.json of a checkpoint's report: what was evaluated, on what, with which settings.
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
                       const train::DynamicsModel& model, const tokenize::Tokenizer& tok,
                       const tokens::TokenDataset& data, const shard::DatasetReader& shards);

}  // namespace wm::evaluate

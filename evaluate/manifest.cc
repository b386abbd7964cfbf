#include "evaluate/manifest.h"

#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/paths.h"
#include "core/provenance.h"
#include "core/sha256.h"
#include "core/shard/dataset_reader.h"
#include "core/tokens/token_dataset.h"
#include "tokenize/tokenizer.h"
#include "train/dynamics_model.h"
#include "trainkit/torch_runtime.h"

namespace wm::evaluate {
namespace fs = std::filesystem;

void CheckInputsBelongTogether(const tokens::TokenDataset& tokens, const tokenize::Tokenizer& tok,
                               const shard::DatasetReader& shards) {
  const std::string index = (fs::path(tokens.dir()) / "index.json").string();
  Check(tokens.index().tokenizer.checkpoint_sha256 == tok.checkpoint_sha256(),
        "the token dataset was written by another tokenizer than --tokenizer",
        {.file = index, .key = "tokenizer.checkpoint_sha256"});
  nlohmann::json shard_hashes = nlohmann::json::array();
  for (const auto& s : shards.index().shards) {
    shard_hashes.push_back({{"file", s.file}, {"sha256", s.sha256}});
  }
  Check(tokens.index().source.value("shards", nlohmann::json()) == shard_hashes,
        "the token dataset was encoded from other shards than --data " + shards.dir(),
        {.file = index, .key = "source.shards"});
}

std::string ReportName(const EvalOptions& o, size_t c) {
  if (c < o.names.size()) return o.names[c];
  fs::path p(o.checkpoints.at(c));
  if (p.extension() == ".wmt") p = p.parent_path();
  return p.filename().string();
}

// wm-eval --policy's settings: the policies by name and command, the closed loop's rules and the
// true values it is compared with.
nlohmann::json PolicyEvalConfigJson(const PolicyEvalOptions& p) {
  nlohmann::json policies = nlohmann::json::array();
  for (const auto& s : p.policies) {
    policies.push_back(
        {{"name", s.name}, {"command", s.command}, {"in_distribution", s.in_distribution}});
  }
  nlohmann::json config = {
      {"policies", policies},
      {"horizon", p.loop.horizon},
      {"rollouts", p.loop.rollouts},
      {"batch", p.loop.batch},  // the frames depend on it through float rounding
      {"clamp_actions", p.loop.clamp_tabletop ? "tabletop" : "none"},
      {"success_threshold", p.loop.success_threshold},
      {"terminal_threshold", p.loop.terminal_threshold},
      {"true_values_sha256", p.true_values.empty() ? "" : Sha256File(p.true_values)}};
  // Only when on, so other runs' config hashes are what they always were.
  if (p.loop.rolling_cache) config["rolling_cache"] = true;
  // Only with a success classifier, so a token model's config hash is what it always was.
  if (!p.success_model.empty()) {
    config["success_model_sha256"] = Sha256File(CheckpointFileIn(p.success_model));
  }
  return config;
}

nlohmann::json EvalConfigJson(const EvalOptions& o) {
  nlohmann::json modes = nlohmann::json::array();
  for (RolloutMode m : o.modes) modes.push_back(RolloutName(m));
  nlohmann::json config = {
      {"rollouts", modes},
      {"horizon", o.rollout.horizon},
      {"context", o.rollout.context},
      {"samples", o.rollout.samples},
      {"seed", o.rollout.seed},
      {"temperature", o.rollout.temperature},
      {"decode_steps", o.rollout.decode_steps},
      {"policy_prefix", o.rollout.policy_prefix},
      {"controllability", PerturbationName(o.controllability)},
      {"max_episodes", o.max_episodes},
      {"resamples", o.resamples},
      {"masks", o.masks.source},
      {"seg_config_sha256", o.masks.seg_config.empty() ? "" : Sha256File(o.masks.seg_config)},
      {"intrinsics", o.masks.intrinsics},
      {"lpips_weights_sha256", o.lpips_weights.empty() ? "" : Sha256File(o.lpips_weights)}};
  // Only when asked for, so a report without it keeps its config hash.
  if (!o.retrace_ks.empty()) config["retrace_ks"] = o.retrace_ks;
  // Only in policy mode, so an open-loop report's config hash is what it always was.
  if (!o.policy_eval.policies.empty()) config["policy_eval"] = PolicyEvalConfigJson(o.policy_eval);
  return config;
}

CheckpointInfo DescribeDynamicsCheckpoint(const train::DynamicsModel& model) {
  return {.file = model.checkpoint_file(),
          .step = model.step(),
          .extra = {{"policy_conditioning", model.config().model.policy_conditioning}}};
}

void WriteEvalManifest(const std::string& dir, const std::string& name,
                       const std::string& checkpoint, const EvalOptions& o,
                       const CheckpointInfo& info, const tokenize::Tokenizer& tok,
                       const tokens::TokenDataset& data, const shard::DatasetReader& shards) {
  nlohmann::json m = MakeProvenance("wm-eval", EvalConfigJson(o), trainkit::TorchLibraryVersions());
  m["checkpoint"] = {{"name", name},
                     {"path_basename", fs::path(checkpoint).filename().string()},
                     {"sha256", Sha256File(info.file)},
                     {"step", info.step}};
  m["checkpoint"].update(info.extra);
  m["seed"] = o.rollout.seed;
  m["tokenizer"] = {{"sha256", tok.checkpoint_sha256()}, {"config_hash", tok.config_hash()}};
  nlohmann::json parts = nlohmann::json::array();
  for (const auto& p : data.index().parts)
    parts.push_back({{"file", p.file}, {"sha256", p.sha256}});
  nlohmann::json shard_files = nlohmann::json::array();
  for (const auto& s : shards.index().shards) {
    shard_files.push_back({{"file", s.file}, {"sha256", s.sha256}});
  }
  m["data"] = {{"dataset", shards.index().dataset},
               {"split", shards.index().split},
               {"shards", shard_files},
               {"token_parts", parts}};
  WriteFileAtomically((fs::path(dir) / "manifest.json").string(), m.dump(2) + "\n");
}

}  // namespace wm::evaluate

#include "evaluate/manifest.h"

#include <filesystem>

#include "core/atomic_file.h"
#include "core/provenance.h"
#include "core/sha256.h"
#include "core/shard/dataset_reader.h"
#include "core/tokens/token_dataset.h"
#include "tokenize/tokenizer.h"
#include "tokenize/trainer.h"
#include "train/dynamics_model.h"

namespace wm::evaluate {
namespace fs = std::filesystem;

nlohmann::json EvalConfigJson(const EvalOptions& o) {
  nlohmann::json modes = nlohmann::json::array();
  for (RolloutMode m : o.modes) modes.push_back(RolloutName(m));
  return {{"rollouts", modes},
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
}

void WriteEvalManifest(const std::string& dir, const std::string& name,
                       const std::string& checkpoint, const EvalOptions& o,
                       const train::DynamicsModel& model, const tokenize::Tokenizer& tok,
                       const tokens::TokenDataset& data, const shard::DatasetReader& shards) {
  nlohmann::json m =
      MakeProvenance("wm-eval", EvalConfigJson(o), {{"libtorch", tokenize::TorchVersion()}});
  m["checkpoint"] = {{"name", name},
                     {"path_basename", fs::path(checkpoint).filename().string()},
                     {"sha256", Sha256File(model.checkpoint_file())},
                     {"step", model.step()},
                     {"policy_conditioning", model.config().model.policy_conditioning}};
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

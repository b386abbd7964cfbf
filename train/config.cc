#include "train/config.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <map>
#include <set>

#include "core/atomic_file.h"
#include "core/episode.h"
#include "core/error.h"
#include "core/sectioned_yaml.h"
#include "core/tokens/token_dataset.h"
#include "trainkit/train_fields.h"

namespace wm::train {
namespace {

// Calls f(section, key, field) for every field: the one list of names shared by the YAML
// reader, the JSON writer and the JSON reader.
template <class Config, class F>
void VisitFields(Config& c, F&& f) {
  auto& m = c.model;
  f("model", "grid_h", m.grid_h);
  f("model", "grid_w", m.grid_w);
  f("model", "num_codes", m.num_codes);
  f("model", "context_frames", m.context_frames);
  f("model", "d_model", m.d_model);
  f("model", "num_layers", m.num_layers);
  f("model", "num_heads", m.num_heads);
  f("model", "mlp_ratio", m.mlp_ratio);
  f("model", "norm", m.norm);
  f("model", "policy_conditioning", m.policy_conditioning);
  f("model", "action_conditioning", m.action_conditioning);
  f("model", "tied_token_head", m.tied_token_head);
  f("model", "mask_frame_prob", m.mask_frame_prob);
  f("model", "objective", m.objective);
  f("model", "copy_prior", m.copy_prior);
  f("model", "temporal_positions", m.temporal_positions);
  f("model", "adaptive_norm", m.adaptive_norm);
  f("model", "decode_steps", m.decode_steps);
  f("model", "decode_temperature", m.decode_temperature);
  auto& p = c.policy;
  f("policy", "d_model", p.d_model);
  f("policy", "num_heads", p.num_heads);
  f("policy", "posterior_layers", p.posterior_layers);
  f("policy", "prior_layers", p.prior_layers);
  f("policy", "decoder_layers", p.decoder_layers);
  f("policy", "categories", p.categories);
  f("policy", "classes", p.classes);
  f("policy", "log_std_min", p.log_std_min);
  f("policy", "log_std_max", p.log_std_max);
  f("policy", "kl_beta", p.kl_beta);
  auto& t = c.train;
  trainkit::VisitOptimizerFields(t, f);
  f("train", "policy_weight", t.policy_weight);
  f("train", "reward_weight", t.reward_weight);
  f("train", "terminal_weight", t.terminal_weight);
  f("train", "bf16", t.bf16);
  trainkit::VisitRunFields(t, f);
  f("train", "val_batches", t.val_batches);
  f("data", "mixture", c.data.mixture);
}

}  // namespace

DynamicsConfig ParseDynamicsConfig(const std::string& yaml_text, const std::string& file) {
  DynamicsConfig config;
  ReadSectionedYaml(yaml_text, file, "docs/dynamics.md", config,
                    [](auto& c, auto&& f) { VisitFields(c, f); });
  ValidateConfig(config, file);
  return config;
}

DynamicsConfig LoadDynamicsConfig(const std::string& path) {
  return ParseDynamicsConfig(ReadFile(path), path);
}

nlohmann::json ConfigToJson(const DynamicsConfig& config) {
  nlohmann::json j = SectionedToJson(config, [](auto& c, auto&& f) { VisitFields(c, f); });
  if (config.model.action_dim != kActionDim) j["model"]["action_dim"] = config.model.action_dim;
  if (config.model.levels != 1) j["model"]["levels"] = config.model.levels;
  // Configs and checkpoints from before rotary time keep their bytes and hashes.
  if (config.model.temporal_positions == "learned") j["model"].erase("temporal_positions");
  if (config.model.adaptive_norm == "none") j["model"].erase("adaptive_norm");
  return j;
}

DynamicsConfig ConfigFromJson(const nlohmann::json& j) {
  auto c = SectionedFromJson<DynamicsConfig>(j, [](auto& c, auto&& f) { VisitFields(c, f); });
  if (j.contains("model") && j["model"].contains("action_dim")) {
    j["model"]["action_dim"].get_to(c.model.action_dim);
  }
  if (j.contains("model") && j["model"].contains("levels")) {
    j["model"]["levels"].get_to(c.model.levels);
  }
  return c;
}

void ValidateConfig(const DynamicsConfig& c, const std::string& file) {
  const auto require = trainkit::FieldRequirement(file);
  const ModelConfig& m = c.model;
  require(m.grid_h > 0, "model.grid_h", "must be > 0");
  require(m.grid_w > 0, "model.grid_w", "must be > 0");
  require(m.num_codes >= 2, "model.num_codes", "must be >= 2");
  require(m.context_frames >= 2, "model.context_frames", "must be >= 2");
  require(m.num_heads > 0, "model.num_heads", "must be > 0");
  require(m.d_model > 0 && m.d_model % m.num_heads == 0, "model.d_model",
          "must be a positive multiple of model.num_heads");
  require(m.num_layers > 0, "model.num_layers", "must be > 0");
  require(m.mlp_ratio > 0, "model.mlp_ratio", "must be > 0");
  require(m.norm == "layernorm" || m.norm == "rmsnorm", "model.norm",
          "must be 'layernorm' or 'rmsnorm'");
  require(m.mask_frame_prob > 0 && m.mask_frame_prob <= 1, "model.mask_frame_prob",
          "must be in (0, 1]");
  require(m.objective == "masked" || m.objective == "next_frame", "model.objective",
          "must be 'masked' or 'next_frame'");
  require(m.temporal_positions == "learned" || m.temporal_positions == "rope",
          "model.temporal_positions", "must be 'learned' or 'rope'");
  require(m.adaptive_norm == "none" || m.adaptive_norm == "identity" || m.adaptive_norm == "zero",
          "model.adaptive_norm", "must be 'none', 'identity' or 'zero'");
  require(m.decode_steps > 0, "model.decode_steps", "must be > 0");
  require(m.decode_temperature >= 0, "model.decode_temperature", "must be >= 0");
  require(m.action_dim >= 1 && m.action_dim <= kMaxActionDim, "model.action_dim",
          "must be in [1, " + std::to_string(kMaxActionDim) + "]");
  require(m.levels >= 1 && m.levels <= tokens::kMaxTokenLevels, "model.levels",
          "must be in [1, " + std::to_string(tokens::kMaxTokenLevels) + "]");
  const PolicyConfig& p = c.policy;
  require(p.num_heads > 0, "policy.num_heads", "must be > 0");
  require(p.d_model > 0 && p.d_model % p.num_heads == 0, "policy.d_model",
          "must be a positive multiple of policy.num_heads");
  require(p.posterior_layers > 0, "policy.posterior_layers", "must be > 0");
  require(p.prior_layers > 0, "policy.prior_layers", "must be > 0");
  require(p.decoder_layers > 0, "policy.decoder_layers", "must be > 0");
  require(p.categories > 0, "policy.categories", "must be > 0");
  require(p.classes >= 2, "policy.classes", "must be >= 2");
  require(p.log_std_min < p.log_std_max, "policy.log_std_min", "must be < policy.log_std_max");
  require(p.kl_beta >= 0, "policy.kl_beta", "must be >= 0");
  const TrainConfig& t = c.train;
  trainkit::ValidateOptimizerFields(t, file);
  require(t.policy_weight >= 0, "train.policy_weight", "must be >= 0");
  require(t.reward_weight >= 0, "train.reward_weight", "must be >= 0");
  require(t.terminal_weight >= 0, "train.terminal_weight", "must be >= 0");
  trainkit::ValidateRunFields(t, file);
  require(t.val_every > 0, "train.val_every", "must be > 0");
  require(t.val_batches > 0, "train.val_batches", "must be > 0");
}

}  // namespace wm::train

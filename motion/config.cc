#include "motion/config.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/sectioned_yaml.h"
#include "trainkit/train_fields.h"

namespace wm::motion {
namespace {

// Calls f(section, key, field) for every field: the one list of names shared by the YAML
// reader, the JSON writer and the JSON reader.
template <class Config, class F>
void VisitFields(Config& c, F&& f) {
  auto& m = c.model;
  f("model", "kind", m.kind);
  f("model", "image_size", m.image_size);
  f("model", "channels", m.channels);
  f("model", "flow_scale", m.flow_scale);
  f("model", "gate_bias", m.gate_bias);
  f("model", "action_jacobian", m.action_jacobian);
  f("model", "layers", m.layers);
  f("model", "pose_dim", m.pose_dim);
  f("model", "renderer_width", m.renderer_width);
  f("model", "dynamics_hidden", m.dynamics_hidden);
  auto& t = c.train;
  trainkit::VisitOptimizerFields(t, f);
  trainkit::VisitRunFields(t, f);
  f("train", "unroll", t.unroll);
  f("train", "val_episodes", t.val_episodes);
  f("train", "val_horizon", t.val_horizon);
  f("train", "mask_l1", t.mask_l1);
  f("train", "mask_noise", t.mask_noise);
  f("train", "mask_noise_ramp", t.mask_noise_ramp);
  f("train", "motion_prior", t.motion_prior);
  f("train", "motion_prior_steps", t.motion_prior_steps);
  f("train", "moved_weight", t.moved_weight);
  f("train", "squared_until", t.squared_until);
  f("train", "pair_window", t.pair_window);
  f("train", "edge_weight", t.edge_weight);
  f("train", "calibrate_alpha", t.calibrate_alpha);
  f("train", "dynamics_steps", t.dynamics_steps);
  f("train", "dynamics_batch", t.dynamics_batch);
  f("train", "dynamics_lr", t.dynamics_lr);
  f("data", "image_key", c.data.image_key);
}

}  // namespace

MotionConfig ParseMotionConfig(const std::string& yaml_text, const std::string& file) {
  MotionConfig config;
  ReadSectionedYaml(yaml_text, file, "docs/motion.md", config,
                    [](auto& c, auto&& f) { VisitFields(c, f); });
  ValidateConfig(config, file);
  return config;
}

MotionConfig LoadMotionConfig(const std::string& path) {
  return ParseMotionConfig(ReadFile(path), path);
}

nlohmann::json ConfigToJson(const MotionConfig& config) {
  return SectionedToJson(config, [](auto& c, auto&& f) { VisitFields(c, f); });
}

MotionConfig ConfigFromJson(const nlohmann::json& j) {
  return SectionedFromJson<MotionConfig>(j, [](auto& c, auto&& f) { VisitFields(c, f); });
}

void ValidateConfig(const MotionConfig& c, const std::string& file) {
  const auto require = trainkit::FieldRequirement(file);
  const ModelConfig& m = c.model;
  require(m.image_size >= 8 && m.image_size % 8 == 0, "model.image_size",
          "must be a positive multiple of 8 (three stride-2 levels)");
  require(m.channels > 0, "model.channels", "must be > 0");
  require(m.flow_scale > 0, "model.flow_scale", "must be > 0");
  require(m.kind == "warp" || m.kind == "layers" || m.kind == "pose", "model.kind",
          "must be warp, layers or pose");
  require(m.layers >= 1, "model.layers", "must be >= 1");
  require(m.kind == "warp" || m.image_size % 16 == 0, "model.image_size",
          "must be a multiple of 16 with model.kind " + m.kind + " (its CNNs halve it four times)");
  require(m.pose_dim >= 1, "model.pose_dim", "must be >= 1");
  require(m.renderer_width >= 4 && m.renderer_width % 4 == 0, "model.renderer_width",
          "must be a positive multiple of 4");
  require(m.dynamics_hidden >= 1, "model.dynamics_hidden", "must be >= 1");
  const TrainConfig& t = c.train;
  trainkit::ValidateOptimizerFields(t, file);
  trainkit::ValidateRunFields(t, file);
  require(t.val_every >= 0, "train.val_every", "must be >= 0");
  require(t.unroll >= 1, "train.unroll", "must be >= 1");
  require(t.val_episodes >= 1, "train.val_episodes", "must be >= 1");
  require(t.val_horizon >= 1, "train.val_horizon", "must be >= 1");
  require(t.mask_l1 >= 0, "train.mask_l1", "must be >= 0");
  require(t.mask_noise >= 0, "train.mask_noise", "must be >= 0");
  require(t.mask_noise_ramp >= 0 && t.mask_noise_ramp <= 1, "train.mask_noise_ramp",
          "must be in [0, 1]");
  require(t.motion_prior >= 0, "train.motion_prior", "must be >= 0");
  require(t.motion_prior_steps >= 0 && t.motion_prior_steps <= 1, "train.motion_prior_steps",
          "must be in [0, 1]");
  require(t.moved_weight >= 0, "train.moved_weight", "must be >= 0");
  require(t.squared_until >= 0 && t.squared_until <= 1, "train.squared_until", "must be in [0, 1]");
  require(t.pair_window >= 0, "train.pair_window", "must be >= 0");
  require(t.edge_weight >= 0, "train.edge_weight", "must be >= 0");
  require(t.dynamics_steps >= 0, "train.dynamics_steps", "must be >= 0");
  require(t.dynamics_batch >= 1, "train.dynamics_batch", "must be >= 1");
  require(t.dynamics_lr > 0, "train.dynamics_lr", "must be > 0");
  require(!c.data.image_key.empty(), "data.image_key", "must not be empty");
}

}  // namespace wm::motion

#pragma once
// SuccessConfig: every knob of the success classifier (success/success_net.h) and its training
// run, loaded from YAML (configs/success/*.yaml). Each field's meaning and default is documented
// in docs/success.md; the defaults below are the `tiny` CPU preset.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

namespace wm::success {

struct ModelConfig {
  int image_size = 64;  // frames are resized (INTER_AREA) to image_size x image_size
  int channels = 16;    // width of the first conv; doubled at each of the three stride-2 levels
};

struct TrainConfig {
  int batch_size = 32;
  int64_t steps = 1500;
  double max_lr = 2e-3;
  double min_lr = 1e-4;
  int64_t warmup_steps = 20;
  double beta1 = 0.9, beta2 = 0.99;
  double weight_decay = 0.01;
  double grad_clip = 1.0;  // max global L2 norm of the gradients (0 = off)
  uint64_t seed = 0;
  int threads = 1;  // LibTorch intra-op threads; fixed so CPU runs are reproducible
  int64_t checkpoint_every = 500;
  int64_t log_every = 20;
  int64_t val_every = 0;  // val.csv period in steps with --val-data (0: only at the end)
  // Share of success frames in every batch: they are rare (one per successful episode), so
  // batches are balanced instead of drawn as the data is (docs/success.md, "Training").
  double positive_fraction = 0.25;
};

struct DataConfig {
  std::string image_key = "image";  // Episode::images stream to train on
  // A frame is a success frame when the reward logged with it exceeds this (tabletop: 1 on the
  // step whose frame shows the block in the goal, else 0).
  double reward_threshold = 0.5;
};

struct SuccessConfig {
  ModelConfig model;
  TrainConfig train;
  DataConfig data;
};

// Parses and validates a YAML file. Unknown keys, wrong types and out-of-range values throw
// wm::Error naming the file and the key (e.g. "train.positive_fraction").
SuccessConfig LoadSuccessConfig(const std::string& path);
SuccessConfig ParseSuccessConfig(const std::string& yaml_text, const std::string& file);

// The config as JSON (for manifests and wm::ConfigHash), and back.
nlohmann::json ConfigToJson(const SuccessConfig& config);
SuccessConfig ConfigFromJson(const nlohmann::json& j);

// Throws wm::Error (key named, `file` attached) when a value is out of range.
void ValidateConfig(const SuccessConfig& config, const std::string& file);

}  // namespace wm::success

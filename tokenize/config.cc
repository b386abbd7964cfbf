#include "tokenize/config.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/sectioned_yaml.h"
#include "trainkit/train_fields.h"

namespace wm::tokenize {
namespace {

// Calls f(section, key, field) for every field: the one list of names shared by the YAML
// reader, the JSON writer and the JSON reader.
template <class Config, class F>
void VisitFields(Config& c, F&& f) {
  auto& m = c.model;
  f("model", "image_size", m.image_size);
  f("model", "patch_size", m.patch_size);
  f("model", "stem_factor", m.stem_factor);
  f("model", "encoder", m.encoder);
  f("model", "encoder_channels", m.encoder_channels);
  f("model", "encoder_layers", m.encoder_layers);
  f("model", "decoder_channels", m.decoder_channels);
  f("model", "min_channels", m.min_channels);
  f("model", "decoder_layers", m.decoder_layers);
  f("model", "latent_dim", m.latent_dim);
  f("model", "num_codes", m.num_codes);
  f("model", "l2_normalize", m.l2_normalize);
  f("model", "beta", m.beta);
  f("model", "dead_code_steps", m.dead_code_steps);
  f("model", "detail_weight", m.detail_weight);
  f("model", "anchor_decoder", m.anchor_decoder);
  f("model", "anchor_flow", m.anchor_flow);
  f("model", "change_weight", m.change_weight);
  f("model", "levels", m.levels);
  auto& t = c.train;
  trainkit::VisitOptimizerFields(t, f);
  trainkit::VisitRunFields(t, f);
  f("train", "val_frames", t.val_frames);
  f("train", "anchor_max_gap", t.anchor_max_gap);
  f("train", "anchor_dropout", t.anchor_dropout);
  f("data", "image_key", c.data.image_key);
}

}  // namespace

TokenizerConfig ParseTokenizerConfig(const std::string& yaml_text, const std::string& file) {
  TokenizerConfig config;
  ReadSectionedYaml(yaml_text, file, "docs/tokenizer.md", config,
                    [](auto& c, auto&& f) { VisitFields(c, f); });
  ValidateConfig(config, file);
  return config;
}

TokenizerConfig LoadTokenizerConfig(const std::string& path) {
  return ParseTokenizerConfig(ReadFile(path), path);
}

nlohmann::json ConfigToJson(const TokenizerConfig& config) {
  return SectionedToJson(config, [](auto& c, auto&& f) { VisitFields(c, f); });
}

TokenizerConfig ConfigFromJson(const nlohmann::json& j) {
  return SectionedFromJson<TokenizerConfig>(j, [](auto& c, auto&& f) { VisitFields(c, f); });
}

void ValidateConfig(const TokenizerConfig& c, const std::string& file) {
  const auto require = trainkit::FieldRequirement(file);
  const ModelConfig& m = c.model;
  const bool pow2 = m.patch_size > 0 && (m.patch_size & (m.patch_size - 1)) == 0;
  require(pow2, "model.patch_size", "must be a power of 2");
  require(m.image_size > 0 && m.image_size % m.patch_size == 0, "model.image_size",
          "must be a positive multiple of model.patch_size");
  const bool stem_pow2 = m.stem_factor > 0 && (m.stem_factor & (m.stem_factor - 1)) == 0;
  require(stem_pow2 && m.stem_factor <= m.patch_size, "model.stem_factor",
          "must be a power of 2 no larger than model.patch_size");
  require(m.encoder == "conv" || m.encoder == "cell_local", "model.encoder",
          "must be conv or cell_local");
  require(m.encoder_channels > 0, "model.encoder_channels", "must be > 0");
  require(m.decoder_channels > 0, "model.decoder_channels", "must be > 0");
  require(m.min_channels >= 0 && m.min_channels <= std::min(m.encoder_channels, m.decoder_channels),
          "model.min_channels", "must be in [0, min(encoder_channels, decoder_channels)]");
  require(m.encoder_layers >= 0, "model.encoder_layers", "must be >= 0");
  require(m.decoder_layers >= 0, "model.decoder_layers", "must be >= 0");
  require(m.latent_dim > 0, "model.latent_dim", "must be > 0");
  require(m.num_codes >= 2, "model.num_codes", "must be >= 2");
  require(m.levels >= 1 && m.levels <= 8, "model.levels", "must be in [1, 8]");
  require(m.beta >= 0, "model.beta", "must be >= 0");
  require(m.dead_code_steps >= 0, "model.dead_code_steps", "must be >= 0");
  require(m.detail_weight >= 0, "model.detail_weight", "must be >= 0");
  require(!m.anchor_flow || m.anchor_decoder, "model.anchor_flow",
          "needs model.anchor_decoder: true (it moves the anchor)");
  require(m.change_weight >= 0, "model.change_weight", "must be >= 0");
  require(m.change_weight == 0 || m.anchor_decoder, "model.change_weight",
          "needs model.anchor_decoder: true (change is measured against the anchor)");
  const TrainConfig& t = c.train;
  trainkit::ValidateOptimizerFields(t, file);
  trainkit::ValidateRunFields(t, file);
  require(t.val_every >= 0, "train.val_every", "must be >= 0");
  require(t.val_frames > 0, "train.val_frames", "must be > 0");
  require(t.anchor_max_gap >= 1, "train.anchor_max_gap", "must be >= 1");
  require(t.anchor_dropout >= 0 && t.anchor_dropout <= 1, "train.anchor_dropout",
          "must be in [0, 1]");
  require(!c.data.image_key.empty(), "data.image_key", "must not be empty");
}

}  // namespace wm::tokenize

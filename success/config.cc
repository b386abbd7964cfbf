#include "success/config.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/sectioned_yaml.h"
#include "trainkit/train_fields.h"

namespace wm::success {
namespace {

// Calls f(section, key, field) for every field: the one list of names shared by the YAML
// reader, the JSON writer and the JSON reader.
template <class Config, class F>
void VisitFields(Config& c, F&& f) {
  f("model", "image_size", c.model.image_size);
  f("model", "channels", c.model.channels);
  auto& t = c.train;
  trainkit::VisitOptimizerFields(t, f);
  trainkit::VisitRunFields(t, f);
  f("train", "positive_fraction", t.positive_fraction);
  f("data", "image_key", c.data.image_key);
  f("data", "reward_threshold", c.data.reward_threshold);
}

}  // namespace

SuccessConfig ParseSuccessConfig(const std::string& yaml_text, const std::string& file) {
  SuccessConfig config;
  ReadSectionedYaml(yaml_text, file, "docs/success.md", config,
                    [](auto& c, auto&& f) { VisitFields(c, f); });
  ValidateConfig(config, file);
  return config;
}

SuccessConfig LoadSuccessConfig(const std::string& path) {
  return ParseSuccessConfig(ReadFile(path), path);
}

nlohmann::json ConfigToJson(const SuccessConfig& config) {
  return SectionedToJson(config, [](auto& c, auto&& f) { VisitFields(c, f); });
}

SuccessConfig ConfigFromJson(const nlohmann::json& j) {
  return SectionedFromJson<SuccessConfig>(j, [](auto& c, auto&& f) { VisitFields(c, f); });
}

void ValidateConfig(const SuccessConfig& c, const std::string& file) {
  const auto require = trainkit::FieldRequirement(file);
  require(c.model.image_size >= 8 && c.model.image_size % 8 == 0, "model.image_size",
          "must be a positive multiple of 8 (three stride-2 levels)");
  require(c.model.channels > 0, "model.channels", "must be > 0");
  const TrainConfig& t = c.train;
  trainkit::ValidateOptimizerFields(t, file);
  trainkit::ValidateRunFields(t, file);
  require(t.val_every >= 0, "train.val_every", "must be >= 0");
  require(t.positive_fraction > 0 && t.positive_fraction < 1, "train.positive_fraction",
          "must be in (0, 1)");
  require(!c.data.image_key.empty(), "data.image_key", "must not be empty");
}

}  // namespace wm::success

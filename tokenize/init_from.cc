#include "tokenize/init_from.h"

#include "core/error.h"

namespace wm::tokenize {
namespace {

// The keys that shape the parameters or the token grid and lookup; the loss weights, dead-code
// period and the schedule may change in a fine-tune.
const std::vector<std::string> kShapeKeys = {
    "model.image_size",       "model.patch_size",     "model.stem_factor",
    "model.encoder_channels", "model.encoder_layers", "model.decoder_channels",
    "model.decoder_layers",   "model.min_channels",   "model.latent_dim",
    "model.num_codes",        "model.l2_normalize",   "model.anchor_decoder",
    "model.anchor_flow",      "model.levels",         "model.encoder"};

}  // namespace

std::optional<trainkit::Parent> ReadTokenizerParent(const TrainOptions& o) {
  if (o.init_from.empty()) return std::nullopt;
  trainkit::Parent parent = trainkit::ReadParent(o.init_from, o.freeze);
  const nlohmann::json& meta = parent.meta();
  // A wm-train archive has the same meta keys, and a "model" tag the tokenizer's lacks.
  if (meta.contains("model") || !meta.contains("config")) {
    throw trainkit::ParentError(parent, parent.archive->path() + ": not a tokenizer checkpoint");
  }
  trainkit::CheckSameShapes(parent, ConfigToJson(ConfigFromJson(meta.at("config"))),
                            ConfigToJson(o.config), kShapeKeys);
  return parent;
}

std::vector<std::string> FrozenPrefixes(const TrainOptions& o) {
  return trainkit::FrozenPrefixes(o.freeze, {{"encoder", {"encoder.", "quantizer."}}},
                                  !o.init_from.empty());
}

}  // namespace wm::tokenize

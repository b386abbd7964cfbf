#include "train/init_from.h"

#include "core/error.h"
#include "core/log.h"
#include "core/provenance.h"

namespace wm::train {
namespace {

// The keys that shape the parameters or what they compute (the token grid, the codebook, widths,
// layer and head counts, which heads exist). The others (objective, masking, decoding, loss
// weights, the schedule) may change in a fine-tune. The action width (model.action_dim, set from
// the data) is checked on its own, so the message can say which data it came from.
const std::vector<std::string> kShapeKeys = {"model.grid_h",
                                             "model.grid_w",
                                             "model.num_codes",
                                             "model.levels",
                                             "model.context_frames",
                                             "model.d_model",
                                             "model.num_layers",
                                             "model.num_heads",
                                             "model.mlp_ratio",
                                             "model.norm",
                                             "model.policy_conditioning",
                                             "model.tied_token_head",
                                             "model.copy_prior",
                                             "model.temporal_positions",
                                             "model.adaptive_norm",
                                             "policy.d_model",
                                             "policy.num_heads",
                                             "policy.posterior_layers",
                                             "policy.prior_layers",
                                             "policy.decoder_layers",
                                             "policy.categories",
                                             "policy.classes"};

// The config as the shape check reads it: every key present (ConfigToJson leaves out a default
// model.temporal_positions, model.adaptive_norm and model.levels, which would read as null).
nlohmann::json ShapeJson(const DynamicsConfig& c) {
  nlohmann::json j = ConfigToJson(c);
  j["model"]["temporal_positions"] = c.model.temporal_positions;
  j["model"]["adaptive_norm"] = c.model.adaptive_norm;
  j["model"]["levels"] = c.model.levels;
  return j;
}

}  // namespace

std::optional<trainkit::Parent> ReadDynamicsParent(const TrainOptions& o) {
  if (o.init_from.empty()) return std::nullopt;
  trainkit::Parent parent = trainkit::ReadParent(o.init_from, o.freeze);
  CheckpointMeta meta;
  try {
    meta = MetaFromJson(parent.meta(), parent.archive->path());
  } catch (const Error& e) {
    throw trainkit::ParentError(parent, e.what());
  }
  const DynamicsConfig theirs = ConfigFromJson(meta.config);
  trainkit::CheckSameShapes(parent, ShapeJson(theirs), ShapeJson(o.config), kShapeKeys);
  if (theirs.model.action_dim != o.config.model.action_dim) {
    throw trainkit::ParentError(parent, "the parent takes " +
                                            std::to_string(theirs.model.action_dim) +
                                            "-dim actions, this token data has " +
                                            std::to_string(o.config.model.action_dim));
  }
  return parent;
}

std::vector<std::string> FrozenPrefixes(const TrainOptions& o) {
  return trainkit::FrozenPrefixes(o.freeze, {{"policy", {"policy."}}}, !o.init_from.empty());
}

void AdoptParent(const trainkit::Parent& parent, CheckpointMeta& meta) {
  const CheckpointMeta theirs = MetaFromJson(parent.meta(), parent.archive->path());
  meta.init_from = parent.record;
  meta.config_hash = ConfigHash(trainkit::HashedConfig(meta.config, meta.init_from));
  nlohmann::json norms = theirs.action_norms;
  for (const auto& [dataset, norm] : meta.action_norms.items()) norms[dataset] = norm;
  meta.action_norms = norms;
  const nlohmann::json tokenizer = theirs.tokenizer.value("checkpoint_sha256", nlohmann::json());
  if (tokenizer != meta.tokenizer.at("checkpoint_sha256")) {
    LogWarn("--init-from " + parent.given + ": the parent was trained on tokens of tokenizer " +
            tokenizer.dump() + ", this data's tokenizer is " +
            meta.tokenizer.at("checkpoint_sha256").dump() +
            "; its token embeddings mean that tokenizer's codes");
  }
}

}  // namespace wm::train

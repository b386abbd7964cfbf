#pragma once
// --init-from RUN_DIR: a new run that starts from the weights of a finished one, with a fresh
// optimizer and schedule (fine-tuning; docs/tokenizer.md and docs/dynamics.md, "Fine-tuning from a
// run"). wmkit manifests record no paths, so the parent is recorded by what identifies its
// weights: its checkpoint's sha256, config hash and step, plus the parameter groups this run keeps
// frozen. That record joins the run's config hash, so --resume refuses a run directory that was
// fine-tuned from another parent or with other frozen groups. Torch-free.
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/tensor_archive.h"

namespace wm::trainkit {

// The finished run named by --init-from.
struct Parent {
  std::string given;  // RUN_DIR as on the command line: error messages only, never recorded
  std::shared_ptr<const TensorArchiveReader> archive;  // its checkpoint.wmt, open
  // {"checkpoint_sha256", "config_hash", "step", "freeze": [group...]}: what checkpoint.json and
  // the archive meta record as "init_from".
  nlohmann::json record;

  const nlohmann::json& meta() const { return archive->meta(); }
};

// Opens RUN_DIR/checkpoint.wmt (or the file itself, as encode's --checkpoint) and hashes it.
// `freeze`: the parameter groups the new run keeps fixed (recorded sorted, each once).
Parent ReadParent(const std::string& run_dir, const std::vector<std::string>& freeze);

// What a run's config_hash is the hash of: `config`, with "init_from": `init_from` added when the
// run has a parent (null: `config` itself, so runs without one hash as they always did).
nlohmann::json HashedConfig(nlohmann::json config, const nlohmann::json& init_from);

// Throws wm::Error "--init-from RUN_DIR: model.d_model is 128 in the parent, 256 here" for the
// first of `keys` ("section.key") whose value differs between `parent_config` (the parent's
// config with today's defaults filled in) and `config`: the keys that shape the parameters.
void CheckSameShapes(const Parent& parent, const nlohmann::json& parent_config,
                     const nlohmann::json& config, const std::vector<std::string>& keys);

// wm::Error "--init-from RUN_DIR: <message>".
Error ParentError(const Parent& parent, const std::string& message);

// The parameter-name prefixes of the --freeze `groups`, from the stage's `table` (group ->
// prefixes). Throws wm::Error for a group the table lacks, naming the known ones, and when
// `groups` is not empty without a parent (freezing a random init is no fine-tuning).
std::vector<std::string> FrozenPrefixes(
    const std::vector<std::string>& groups,
    const std::map<std::string, std::vector<std::string>>& table, bool has_parent);

// Whether parameter `name` ("policy.prior.0.weight") is frozen: it starts with one of
// `frozen_prefixes` ("policy.").
bool IsFrozen(const std::string& name, const std::vector<std::string>& frozen_prefixes);

}  // namespace wm::trainkit

#pragma once
// The train-section fields both stages' configs have (tokenize::TrainConfig, train::TrainConfig;
// docs/config.md): one list of their names for the config visitors and one set of range checks.
// Header-only templates over a stage's TrainConfig (torch-free); the stages keep their own
// defaults and their own fields, visited and checked between these groups so that the order of
// keys and of errors stays each stage's.
#include <string>

#include "core/error.h"

namespace wm::trainkit {

// f("train", key, field) for the optimizer and schedule fields.
template <class Train, class F>
void VisitOptimizerFields(Train& t, F&& f) {
  f("train", "batch_size", t.batch_size);
  f("train", "steps", t.steps);
  f("train", "max_lr", t.max_lr);
  f("train", "min_lr", t.min_lr);
  f("train", "warmup_steps", t.warmup_steps);
  f("train", "beta1", t.beta1);
  f("train", "beta2", t.beta2);
  f("train", "weight_decay", t.weight_decay);
  f("train", "grad_clip", t.grad_clip);
}

// f("train", key, field) for the run's bookkeeping: seed, threads and the step periods.
template <class Train, class F>
void VisitRunFields(Train& t, F&& f) {
  f("train", "seed", t.seed);
  f("train", "threads", t.threads);
  f("train", "checkpoint_every", t.checkpoint_every);
  f("train", "log_every", t.log_every);
  f("train", "val_every", t.val_every);
}

// require(ok, "train.key", "must be > 0"): throws wm::Error naming `file` and the key unless ok.
inline auto FieldRequirement(const std::string& file) {
  return [&file](bool ok, const char* key, const std::string& what) {
    Check(ok, what, {.file = file, .key = key});
  };
}

// Throws wm::Error naming `file` and "train.<key>" for an optimizer field out of range.
template <class Train>
void ValidateOptimizerFields(const Train& t, const std::string& file) {
  const auto require = FieldRequirement(file);
  require(t.batch_size > 0, "train.batch_size", "must be > 0");
  require(t.steps > 0, "train.steps", "must be > 0");
  require(t.max_lr > 0, "train.max_lr", "must be > 0");
  require(t.min_lr >= 0 && t.min_lr <= t.max_lr, "train.min_lr", "must be in [0, max_lr]");
  require(t.warmup_steps >= 0, "train.warmup_steps", "must be >= 0");
  require(t.beta1 >= 0 && t.beta1 < 1, "train.beta1", "must be in [0, 1)");
  require(t.beta2 >= 0 && t.beta2 < 1, "train.beta2", "must be in [0, 1)");
  require(t.weight_decay >= 0, "train.weight_decay", "must be >= 0");
  require(t.grad_clip >= 0, "train.grad_clip", "must be >= 0");
}

// The same for threads and the checkpoint and log periods (val_every's range is the stage's).
template <class Train>
void ValidateRunFields(const Train& t, const std::string& file) {
  const auto require = FieldRequirement(file);
  require(t.threads > 0, "train.threads", "must be > 0");
  require(t.checkpoint_every > 0, "train.checkpoint_every", "must be > 0");
  require(t.log_every > 0, "train.log_every", "must be > 0");
}

}  // namespace wm::trainkit

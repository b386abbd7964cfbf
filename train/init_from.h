#pragma once
// wm-train --init-from RUN_DIR and --freeze (trainkit/init_from.h; docs/dynamics.md,
// "Fine-tuning from a run"): which config keys must equal the parent's, which parameters a
// frozen group holds, and what the new run's meta takes over from the parent's. Internal header.
#include <optional>
#include <string>
#include <vector>

#include "train/checkpoint.h"
#include "train/trainer.h"
#include "trainkit/init_from.h"

namespace wm::train {

// The run named by options.init_from, checked: a wm-train checkpoint whose parameters have the
// shapes options.config gives (else wm::Error naming the first key that differs and both values).
// nullopt without --init-from.
std::optional<trainkit::Parent> ReadDynamicsParent(const TrainOptions& options);

// The parameter-name prefixes of options.freeze ("policy" -> "policy.": the policy embedding).
std::vector<std::string> FrozenPrefixes(const TrainOptions& options);

// Makes `meta` (a new run's, NewRunMeta) a fine-tune of `parent`: records it as init_from, hashes
// it into config_hash, and keeps the parent's action statistics for the datasets this run does not
// train on (the new data's own statistics win for the others). A parent trained on tokens of
// another tokenizer only warns: its token embeddings then mean other images.
void AdoptParent(const trainkit::Parent& parent, CheckpointMeta& meta);

}  // namespace wm::train

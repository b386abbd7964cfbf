#pragma once
// wm-tokenize train --init-from RUN_DIR and --freeze (trainkit/init_from.h; docs/tokenizer.md,
// "Fine-tuning from a run"): which config keys must equal the parent's and which parameters a
// frozen group holds. Torch-free.
#include <optional>
#include <string>
#include <vector>

#include "tokenize/trainer.h"
#include "trainkit/init_from.h"

namespace wm::tokenize {

// The run named by options.init_from, checked: a tokenizer checkpoint whose parameters have the
// shapes options.config gives (else wm::Error naming the first key that differs and both values).
// nullopt without --init-from.
std::optional<trainkit::Parent> ReadTokenizerParent(const TrainOptions& options);

// The parameter-name prefixes of options.freeze: "encoder" = the encoder and the codebook
// ("encoder.", "quantizer."), so every frame keeps its tokens while the decoder trains.
std::vector<std::string> FrozenPrefixes(const TrainOptions& options);

}  // namespace wm::tokenize

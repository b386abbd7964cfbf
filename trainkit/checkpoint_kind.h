#pragma once
// Checkpoints that say what model they hold (meta "model_kind": "motion", "success"): the test
// whether a path holds one, and the load frame that checks the kind and names the file in every
// error. Torch-free; the stage's `load` callback builds its modules.
#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "core/tensor_archive.h"

namespace wm::trainkit {

// Whether `path` (a RUN_DIR or its checkpoint.wmt) is a checkpoint whose meta says `kind`.
bool IsCheckpointOfKind(const std::string& path, const std::string& kind);

// Opens `file` and runs `load(reader, meta)` after checking meta "model_kind" == `kind` (else
// wm::Error `not_kind`, key model_kind). A wm::Error from either gets `file` attached; a missing
// or mistyped meta key becomes "bad checkpoint meta: ..." naming `file`.
void LoadCheckpointOfKind(
    const std::string& file, const std::string& kind, const std::string& not_kind,
    const std::function<void(const TensorArchiveReader&, const nlohmann::json&)>& load);

}  // namespace wm::trainkit

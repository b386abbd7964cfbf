#pragma once
// wmkit checkpoints (WMTENSR1 archives, core/tensor_archive.h) <-> safetensors files
// (core/safetensors.h), for `wm-checkpoint export|import` (docs/safetensors.md). Torch-free.
#include <cstddef>
#include <string>

namespace wm {

// The prefix of the model's own tensors in a checkpoint; the rest is optimizer state
// ("adamw/exp_avg/...") that PyTorch tools do not want.
inline constexpr const char* kModelTensorPrefix = "model/";
// __metadata__ keys wmkit writes: the archive's meta JSON (config, step, ...) as one string,
// and which tensors the file holds ("model" or "all").
inline constexpr const char* kSafetensorsWmkitMetaKey = "wmkit";
inline constexpr const char* kSafetensorsWmkitTensorsKey = "wmkit_tensors";

struct SafetensorsExportOptions {
  std::string checkpoint;  // a run directory or a .wmt file
  std::string out;         // the .safetensors file to write
  // false: only "model/" tensors, named without the prefix (the PyTorch state_dict names);
  // true: every tensor under its archive name.
  bool all_tensors = false;
};

struct SafetensorsImportOptions {
  std::string safetensors;   // the file to read
  std::string like;          // run directory or .wmt whose other tensors and meta are kept
  std::string out;           // the new .wmt checkpoint
  bool all_tensors = false;  // the file names every archive tensor (an `export --all` file)
};

// Returns the number of tensors written. Throws wm::Error naming the file.
size_t ExportCheckpointSafetensors(const SafetensorsExportOptions& options);
// Replaces `like`'s model tensors (or all, with all_tensors) by the file's, which must have
// exactly the same names, dtypes and shapes (the first difference is the error), and writes the
// result atomically. Returns the number of tensors replaced.
size_t ImportCheckpointSafetensors(const SafetensorsImportOptions& options);

}  // namespace wm

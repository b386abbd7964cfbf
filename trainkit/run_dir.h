#pragma once
// A trainer's output directory RUN_DIR and the checkpoint in it (torch-free): checkpoint.wmt (a
// wmkit tensor archive) and its manifest checkpoint.json, written archive first. The layouts are
// the stages' (docs/tokenizer.md, docs/dynamics.md).
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "core/paths.h"  // kCheckpointFile
#include "core/tensor_archive.h"

namespace wm::trainkit {

inline constexpr const char* kManifestFile = "checkpoint.json";

class RunDir {
 public:
  // Throws wm::Error when `dir` already holds a checkpoint and `resume` is off (a new run would
  // overwrite it). Creates `dir` when `create` (in data-parallel runs only the writing rank).
  RunDir(std::string dir, bool resume, bool create);

  const std::string& dir() const { return dir_; }
  std::string File(const std::string& name) const;  // dir/name
  const std::string& checkpoint() const { return checkpoint_; }
  // --resume and a checkpoint to resume from (a first run with --resume starts from step 0).
  bool resuming() const { return resuming_; }

  // The fields every checkpoint.json has: MakeProvenance(tool, config, LibTorch version), the
  // step and {file, sha256, format} of checkpoint.wmt as it is on disk now. A run started with
  // --init-from also has "init_from" (Parent::record), and its config_hash is that of
  // HashedConfig(config, init_from) (trainkit/init_from.h).
  nlohmann::json Manifest(const std::string& tool, const nlohmann::json& config, int64_t step,
                          const nlohmann::json& init_from = nullptr) const;
  void WriteManifest(const nlohmann::json& manifest) const;  // atomically
  // On resume from `step`: logs it, then writes `manifest` (the loaded archive's) unless
  // checkpoint.json already holds exactly it, so only a manifest left stale by a kill is
  // rewritten (and a read-only run directory fails where it did before, at the first log it
  // appends to).
  void Resumed(int64_t step, const nlohmann::json& manifest) const;

  // Writes checkpoint.wmt (atomically), then the manifest `manifest()` makes. A kill between the
  // two leaves the manifest describing the previous archive, so a resumed run rewrites it
  // (Resumed) from the archive it loaded.
  void WriteCheckpoint(const TensorArchiveWriter& archive,
                       const std::function<nlohmann::json()>& manifest) const;

 private:
  std::string dir_, checkpoint_;
  bool resuming_ = false;
};

}  // namespace wm::trainkit

#include "trainkit/run_dir.h"

#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/log.h"
#include "core/provenance.h"
#include "core/sha256.h"
#include "trainkit/init_from.h"
#include "trainkit/torch_runtime.h"

namespace wm::trainkit {
namespace fs = std::filesystem;

RunDir::RunDir(std::string dir, bool resume, bool create)
    : dir_(std::move(dir)), checkpoint_((fs::path(dir_) / kCheckpointFile).string()) {
  const bool has_checkpoint = fs::exists(checkpoint_);
  Check(resume || !has_checkpoint,
        "run directory already has a checkpoint; pass --resume or choose another --out",
        {.file = checkpoint_});
  resuming_ = resume && has_checkpoint;
  if (create) fs::create_directories(dir_);
}

std::string RunDir::File(const std::string& name) const { return (fs::path(dir_) / name).string(); }

nlohmann::json RunDir::Manifest(const std::string& tool, const nlohmann::json& config, int64_t step,
                                const nlohmann::json& init_from) const {
  nlohmann::json manifest = MakeProvenance(tool, config, TorchLibraryVersions());
  if (!init_from.is_null()) {
    manifest["config_hash"] = ConfigHash(HashedConfig(config, init_from));
    manifest["init_from"] = init_from;
  }
  manifest["step"] = step;
  manifest["checkpoint"] = {{"file", kCheckpointFile},
                            {"sha256", Sha256File(checkpoint_)},
                            {"format", kTensorArchiveFormat}};
  return manifest;
}

void RunDir::WriteManifest(const nlohmann::json& manifest) const {
  WriteFileAtomically(File(kManifestFile), manifest.dump(2) + "\n");
}

void RunDir::Resumed(int64_t step, const nlohmann::json& manifest) const {
  LogInfo("resuming " + checkpoint_ + " at step " + std::to_string(step));
  const std::string path = File(kManifestFile), bytes = manifest.dump(2) + "\n";
  std::error_code ec;
  if (fs::exists(path, ec) && ReadFile(path) == bytes) return;
  WriteFileAtomically(path, bytes);
}

void RunDir::WriteCheckpoint(const TensorArchiveWriter& archive,
                             const std::function<nlohmann::json()>& manifest) const {
  archive.Write(checkpoint_);  // atomic
  WriteManifest(manifest());
}

}  // namespace wm::trainkit

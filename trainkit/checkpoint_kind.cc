#include "trainkit/checkpoint_kind.h"

#include <filesystem>

#include "core/error.h"
#include "core/paths.h"

namespace wm::trainkit {

bool IsCheckpointOfKind(const std::string& path, const std::string& kind) {
  const std::string file = CheckpointFileIn(path);
  if (!std::filesystem::is_regular_file(file)) return false;
  return TensorArchiveReader(file).meta().value("model_kind", "") == kind;
}

void LoadCheckpointOfKind(
    const std::string& file, const std::string& kind, const std::string& not_kind,
    const std::function<void(const TensorArchiveReader&, const nlohmann::json&)>& load) {
  const TensorArchiveReader reader(file);
  try {
    const nlohmann::json& meta = reader.meta();
    Check(meta.value("model_kind", "") == kind, not_kind, {.key = "model_kind"});
    load(reader, meta);
  } catch (const Error& e) {
    throw e.WithFile(file);
  } catch (const nlohmann::json::exception& e) {
    throw Error("bad checkpoint meta: " + std::string(e.what()), {.file = file});
  }
}

}  // namespace wm::trainkit

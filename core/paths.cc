#include "core/paths.h"

#include <cstdlib>
#include <filesystem>

namespace wm {
namespace fs = std::filesystem;

std::string DefaultConfigsDir() {
  if (const char* env = std::getenv("WMKIT_CONFIGS"); env != nullptr && *env != '\0') return env;
  for (fs::path dir = ExecutableDir(); !dir.empty() && dir != dir.root_path();
       dir = dir.parent_path()) {
    if (fs::is_directory(dir / "configs" / "datasets")) return (dir / "configs").string();
  }
  return "configs";
}

std::string ExecutableDir() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? std::string() : exe.parent_path().string();
}

std::string CheckpointFileIn(const std::string& run_dir_or_file) {
  return fs::is_directory(run_dir_or_file) ? (fs::path(run_dir_or_file) / kCheckpointFile).string()
                                           : run_dir_or_file;
}

}  // namespace wm

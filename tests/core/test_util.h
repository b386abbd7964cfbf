#pragma once
// Small helpers shared by the C++ tests: temp directories and a synthetic episode.
#include <filesystem>
#include <functional>
#include <random>
#include <string>

#include "core/episode.h"

namespace wm::test {

// A fresh directory under the system temp dir, removed when the object dies.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  const std::filesystem::path& path() const { return path_; }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

// A deterministic episode with `steps` steps, actions from `seed`, fake JPEG-magic frames.
Episode MakeEpisode(int steps, uint64_t seed, const std::string& key = "ep");

// The repository root and the directory of built tools ($WM_SOURCE_DIR / $WM_BIN_DIR, else the
// paths compiled into the test).
std::string SourceDir();
std::string BinDir();

// The message of the wm::Error that f() throws, or "(no error)".
std::string ErrorText(const std::function<void()>& f);

void FlipByte(const std::string& file, uint64_t offset);
void Truncate(const std::string& file, uint64_t new_size);

}  // namespace wm::test

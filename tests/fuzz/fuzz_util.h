#pragma once
// Shared by the fuzz targets (tests/fuzz/*_fuzz.cc, docs/testing.md). A target feeds the fuzz
// bytes through a reader's public API; a wm::Error is the correct answer to bad input. Anything
// else escaping the target (another exception, a crash, a sanitizer report, a hang) is a bug:
// the project promises one clear wm::Error per bad input, so library exceptions such as
// std::bad_alloc, YAML::Exception or nlohmann::json::exception must not leak out of a reader.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "core/error.h"

namespace wm::fuzz {

// A directory private to this process (created on first use, removed at exit), in memory.
const std::string& TempDir();
// Writes `bytes` to TempDir()/name, replacing what was there; returns the path.
std::string WriteTempFile(const std::string& name, std::string_view bytes);
// The repository root: $WM_SOURCE_DIR, else the one this target was built from.
std::string SourceDir();

// Runs f(); a wm::Error thrown by it is the expected outcome and is swallowed.
template <class F>
void AcceptWmError(F&& f) {
  try {
    f();
  } catch (const Error&) {
  }
}

inline std::string_view Bytes(const uint8_t* data, size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

}  // namespace wm::fuzz

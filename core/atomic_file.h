#pragma once
// Crash-safe writes: bytes go to a hidden temp file beside the target, which is fsynced and
// renamed over the target only on Commit(). A killed process leaves at most a `.NAME.tmp`
// file that readers never open; the target is either absent or complete.
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

namespace wm {

class AtomicFileWriter {
 public:
  explicit AtomicFileWriter(std::string path);
  ~AtomicFileWriter();  // removes the temp file unless committed
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;

  void Write(const void* data, size_t n);
  void Write(std::string_view s) { Write(s.data(), s.size()); }
  uint64_t bytes_written() const { return bytes_; }
  // fflush + fsync + rename + fsync of the directory. Throws wm::Error on any failure.
  void Commit();
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::string temp_path_;
  std::FILE* file_ = nullptr;
  uint64_t bytes_ = 0;
};

// Writes a whole file atomically.
void WriteFileAtomically(const std::string& path, std::string_view contents);
// Reads a whole file; throws wm::Error naming the file.
std::string ReadFile(const std::string& path);
// The hidden temp name used for `path` (`dir/.name.tmp`).
std::string TempPathFor(const std::string& path);

}  // namespace wm

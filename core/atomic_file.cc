#include "core/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"

namespace wm {
namespace fs = std::filesystem;

namespace {
std::string ErrnoText() { return std::strerror(errno); }

void FsyncDirectory(const fs::path& dir) {
  int fd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (fd < 0) return;  // some filesystems do not allow it; the rename itself is still atomic
  ::fsync(fd);
  ::close(fd);
}
}  // namespace

std::string TempPathFor(const std::string& path) {
  fs::path p(path);
  return (p.parent_path() / ("." + p.filename().string() + ".tmp")).string();
}

AtomicFileWriter::AtomicFileWriter(std::string path)
    : path_(std::move(path)), temp_path_(TempPathFor(path_)) {
  file_ = std::fopen(temp_path_.c_str(), "wb");
  // Errors name the file the user asked for; the temp file is an implementation detail.
  Check(file_ != nullptr, "cannot create file (temp " + temp_path_ + "): " + ErrnoText(),
        {.file = path_});
}

AtomicFileWriter::~AtomicFileWriter() {
  if (file_ != nullptr) {
    std::fclose(file_);
    std::remove(temp_path_.c_str());
  }
}

void AtomicFileWriter::Write(const void* data, size_t n) {
  Check(file_ != nullptr, "write after commit", {.file = path_});
  if (n == 0) return;
  if (std::fwrite(data, 1, n, file_) != n) {
    throw Error("write failed (temp " + temp_path_ + "): " + ErrnoText(), {.file = path_});
  }
  bytes_ += n;
}

void AtomicFileWriter::Commit() {
  Check(file_ != nullptr, "commit called twice", {.file = path_});
  bool ok = std::fflush(file_) == 0 && ::fsync(::fileno(file_)) == 0;
  std::string why = ok ? "" : ErrnoText();
  ok = (std::fclose(file_) == 0) && ok;
  file_ = nullptr;
  if (!ok || std::rename(temp_path_.c_str(), path_.c_str()) != 0) {
    if (why.empty()) why = ErrnoText();
    std::remove(temp_path_.c_str());
    throw Error("cannot write file (" + why + "); nothing was replaced", {.file = path_});
  }
  FsyncDirectory(fs::path(path_).parent_path());
}

void WriteFileAtomically(const std::string& path, std::string_view contents) {
  AtomicFileWriter w(path);
  w.Write(contents);
  w.Commit();
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  Check(in.good(), "cannot open file", {.file = path});
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace wm

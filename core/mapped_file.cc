#include "core/mapped_file.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "core/error.h"

namespace wm {

MappedFile::MappedFile(std::string path) : path_(std::move(path)) {
  int fd = ::open(path_.c_str(), O_RDONLY);
  Check(fd >= 0, std::string("cannot open file: ") + std::strerror(errno), {.file = path_});
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    ::close(fd);
    throw Error("cannot stat file", {.file = path_});
  }
  size_ = static_cast<size_t>(st.st_size);
#if WM_MAPPED_FILE_ON_HEAP
  // Sanitizer builds: an exact-size heap copy, so ASan reports any read past the end.
  if (size_ > 0) {
    auto* copy = new uint8_t[size_];
    const bool ok = ::pread(fd, copy, size_, 0) == static_cast<ssize_t>(size_);
    ::close(fd);
    if (!ok) {
      delete[] copy;
      throw Error("cannot read file", {.file = path_});
    }
    data_ = copy;
    return;
  }
#else
  if (size_ > 0) {
    void* p = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd, 0);
    if (p == MAP_FAILED) {
      ::close(fd);
      throw Error(std::string("cannot map file: ") + std::strerror(errno), {.file = path_});
    }
    data_ = static_cast<const uint8_t*>(p);
  }
#endif
  ::close(fd);
}

MappedFile::~MappedFile() {
#if WM_MAPPED_FILE_ON_HEAP
  delete[] data_;
#else
  if (data_ != nullptr) ::munmap(const_cast<uint8_t*>(data_), size_);
#endif
}

}  // namespace wm

#pragma once
// A read-only memory map of a whole file: O(1) random access to records without reading them.
#include <cstdint>
#include <string>
#include <string_view>

namespace wm {

class MappedFile {
 public:
  explicit MappedFile(std::string path);  // throws wm::Error naming the file
  ~MappedFile();
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;

  const uint8_t* data() const { return data_; }
  size_t size() const { return size_; }
  std::string_view view() const { return {reinterpret_cast<const char*>(data_), size_}; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  const uint8_t* data_ = nullptr;
  size_t size_ = 0;
};

}  // namespace wm

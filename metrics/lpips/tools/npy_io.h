#pragma once
// Minimal NumPy .npy (format 1.0-3.0) reading and writing for the LPIPS tools: C-order arrays of
// uint8 ("|u1"), float32 ("<f4") or float64 ("<f8"). Errors are wm::Error naming the file.
#include <cstdint>
#include <string>
#include <vector>

namespace wm::npy {

struct Array {
  std::string descr;           // numpy dtype string, e.g. "|u1", "<f4"
  std::vector<int64_t> shape;  // C order
  std::string bytes;           // the raw little-endian elements
  int64_t numel() const;
};

Array Read(const std::string& path);
// Writes a version 1.0 file (atomically). `bytes` must match numel(shape) * itemsize(descr).
void Write(const std::string& path, const std::string& descr, const std::vector<int64_t>& shape,
           const void* data, size_t bytes);

}  // namespace wm::npy

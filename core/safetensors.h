#pragma once
// The safetensors file format (Hugging Face), so weights move between wmkit and PyTorch / HF
// tools without pickle: a u64 little-endian header length N, N bytes of UTF-8 JSON
// {name: {"dtype", "shape", "data_offsets": [begin, end]}, "__metadata__": {str: str}}, then the
// byte buffer that the offsets index (relative to its start, contiguous, no holes). Layout and
// what wmkit writes into the header: docs/safetensors.md, schemas/safetensors-header.schema.json.
// Torch-free; the checkpoint conversion on top of it is core/checkpoint_safetensors.h.
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/tensor_archive.h"

namespace wm {

// The spec's cap on the header, which also bounds what a damaged length field makes us parse.
inline constexpr uint64_t kSafetensorsMaxHeaderBytes = 100'000'000;
// The header is padded with spaces so the byte buffer starts on a multiple of this.
inline constexpr uint64_t kSafetensorsHeaderAlignment = 8;
inline constexpr const char* kSafetensorsMetadataKey = "__metadata__";

// "F32", "F64", "F16", "I32", "I64", "U8": the safetensors codes of wmkit's dtypes.
std::string SafetensorsDTypeCode(DType dtype);
// Throws wm::Error for a code wmkit does not hold (BF16, BOOL, I8, ...) or an unknown one.
DType ParseSafetensorsDType(const std::string& code);

// One tensor: `bytes` is row-major little-endian data of numel(shape) * DTypeSize(dtype) bytes
// (a view: into the caller's memory when writing, into the mapped file when reading).
struct SafetensorsTensor {
  std::string name;
  DType dtype = DType::kFloat32;
  std::vector<int64_t> shape;
  std::string_view bytes;
};

struct SafetensorsContents {
  std::map<std::string, SafetensorsTensor> tensors;
  std::map<std::string, std::string> metadata;  // "__metadata__"; empty when absent
};

// Parses and validates a whole file held in memory: header length, JSON, every entry's dtype,
// shape and offsets, and that the tensors tile the byte buffer exactly. Errors are wm::Error
// naming `path` and, where one is involved, the tensor as key. Tensor bytes view `file`.
SafetensorsContents ParseSafetensors(std::string_view file, const std::string& path);

// The header bytes wmkit writes for `tensors` in this order (data_offsets accumulate), padded
// with spaces to kSafetensorsHeaderAlignment; without the u64 length in front.
std::string SafetensorsHeader(const std::vector<SafetensorsTensor>& tensors,
                              const std::map<std::string, std::string>& metadata);

// Writes a file atomically (temp file, fsync, rename). Tensors go largest item size first, then
// by name (as the reference writer orders them), so each starts aligned to its item size; the
// same tensors and metadata give the same bytes. Throws on a duplicate name or a size mismatch.
void WriteSafetensors(const std::string& path, std::vector<SafetensorsTensor> tensors,
                      const std::map<std::string, std::string>& metadata);

// A file opened read-only and validated (ParseSafetensors over a memory map).
class SafetensorsReader {
 public:
  explicit SafetensorsReader(const std::string& path);
  ~SafetensorsReader();
  SafetensorsReader(const SafetensorsReader&) = delete;
  SafetensorsReader& operator=(const SafetensorsReader&) = delete;

  const std::string& path() const;
  const SafetensorsContents& contents() const { return contents_; }

 private:
  struct Mapping;
  std::unique_ptr<Mapping> mapping_;
  SafetensorsContents contents_;
};

}  // namespace wm

#pragma once
// wmkit tensor archive ("WMTENSR1"): named, typed, checksummed tensors behind one JSON header,
// readable by numpy and C++ without torch.load. The byte layout is in docs/metrics-lpips.md
// ("Weights file"), the header schema in schemas/lpips-weights.schema.json. Used for the LPIPS
// weights and meant for other checkpoints.
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace wm {

inline constexpr std::string_view kTensorArchiveMagic = "WMTENSR1";
inline constexpr const char* kTensorArchiveFormat = "wmkit-tensors";
inline constexpr int kTensorArchiveVersion = 1;
// The data section and every tensor in it start on a multiple of this many bytes, so a
// memory-mapped float32/float64/int64 tensor is aligned for direct use.
inline constexpr uint64_t kTensorArchiveAlignment = 64;

enum class DType { kFloat32, kFloat64, kFloat16, kInt32, kInt64, kUInt8 };

// "float32", "float64", "float16", "int32", "int64", "uint8" (numpy's names).
std::string DTypeName(DType dtype);
size_t DTypeSize(DType dtype);
// Throws wm::Error for an unknown name.
DType ParseDType(const std::string& name);

// One tensor inside an open archive; `data` points into the archive's mapping (row-major,
// little-endian) and lives as long as the reader.
struct ArchiveTensor {
  std::string name;
  DType dtype = DType::kFloat32;
  std::vector<int64_t> shape;  // empty for a scalar
  const uint8_t* data = nullptr;
  uint64_t length = 0;  // bytes = numel * DTypeSize(dtype)
  int64_t numel() const;
};

// "[64, 3, 11, 11]"
std::string ShapeString(const std::vector<int64_t>& shape);

// Opens and validates a whole archive: magic, header JSON against the format, every tensor's
// bounds, and every tensor's CRC32C (so corruption is reported at open, naming the tensor).
// Errors are wm::Error with the file and, where one is involved, the tensor name as key.
class TensorArchiveReader {
 public:
  explicit TensorArchiveReader(std::string path);
  ~TensorArchiveReader();
  TensorArchiveReader(const TensorArchiveReader&) = delete;
  TensorArchiveReader& operator=(const TensorArchiveReader&) = delete;

  const std::string& path() const { return path_; }
  bool Contains(const std::string& name) const { return tensors_.count(name) > 0; }
  std::vector<std::string> Names() const;  // sorted
  // Throws wm::Error ("missing tensor") naming the file and the tensor.
  const ArchiveTensor& Get(const std::string& name) const;
  // A float32 tensor of exactly `shape`; throws naming file, tensor, and both shapes otherwise.
  std::span<const float> Float32(const std::string& name, const std::vector<int64_t>& shape) const;
  // The header's free-form "meta" object ({} when absent).
  const nlohmann::json& meta() const { return meta_; }

 private:
  struct Mapping;
  std::string path_;
  std::unique_ptr<Mapping> mapping_;
  std::map<std::string, ArchiveTensor> tensors_;
  nlohmann::json meta_;
};

// Collects tensors (copied) and writes them as one archive, atomically (temp file + rename).
class TensorArchiveWriter {
 public:
  // `bytes` must equal numel(shape) * DTypeSize(dtype). Throws on a duplicate name.
  void Add(const std::string& name, DType dtype, std::vector<int64_t> shape, const void* data,
           size_t bytes);
  void AddFloat32(const std::string& name, std::vector<int64_t> shape, const float* data);
  void SetMeta(nlohmann::json meta) { meta_ = std::move(meta); }
  void Write(const std::string& path) const;

 private:
  struct Entry {
    DType dtype;
    std::vector<int64_t> shape;
    std::string bytes;
  };
  std::map<std::string, Entry> entries_;
  nlohmann::json meta_ = nlohmann::json::object();
};

}  // namespace wm

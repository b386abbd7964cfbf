#include "core/tensor_archive.h"

#include <algorithm>
#include <bit>
#include <cstdio>
#include <cstring>

#include "core/atomic_file.h"
#include "core/crc32c.h"
#include "core/error.h"
#include "core/json_int.h"
#include "core/mapped_file.h"

namespace wm {
namespace {

static_assert(std::endian::native == std::endian::little,
              "the tensor archive stores little-endian data and is read in place");

constexpr uint64_t kPreambleSize = 16;  // magic + u64 header length

uint64_t AlignUp(uint64_t n) {
  return (n + kTensorArchiveAlignment - 1) / kTensorArchiveAlignment * kTensorArchiveAlignment;
}

void PutU64(std::string& out, uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}

uint64_t GetU64(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

int64_t NumelOf(const std::vector<int64_t>& shape) {
  int64_t n = 1;
  for (int64_t d : shape) n *= d;
  return n;
}

// Parses one "tensors" entry; `context` names the file and the tensor.
ArchiveTensor ParseEntry(const std::string& name, const nlohmann::json& e, const uint8_t* data,
                         uint64_t data_length, const ErrorContext& context) {
  Check(e.is_object(), "tensor entry is not a JSON object", context);
  for (const char* field : {"dtype", "shape", "offset", "length", "crc32c"}) {
    Check(e.contains(field), std::string("tensor entry lacks field '") + field + "'", context);
  }
  ArchiveTensor t;
  t.name = name;
  try {
    t.dtype = ParseDType(e.at("dtype").get<std::string>());
    t.shape = JsonInts<int64_t>(e.at("shape"));
    const uint64_t offset = JsonInt<uint64_t>(e.at("offset"));
    t.length = JsonInt<uint64_t>(e.at("length"));
    const uint32_t stored_crc = JsonInt<uint32_t>(e.at("crc32c"));
    for (int64_t d : t.shape) Check(d >= 0, "negative dimension in shape " + ShapeString(t.shape));
    Check(t.length == static_cast<uint64_t>(t.numel()) * DTypeSize(t.dtype),
          "length " + std::to_string(t.length) + " does not match shape " + ShapeString(t.shape) +
              " of " + DTypeName(t.dtype));
    Check(offset % kTensorArchiveAlignment == 0,
          "offset " + std::to_string(offset) + " is not 64-byte aligned");
    Check(offset <= data_length && t.length <= data_length - offset,
          "bytes [" + std::to_string(offset) + ", " + std::to_string(offset + t.length) +
              ") lie outside the data section of " + std::to_string(data_length) + " bytes");
    t.data = data + offset;
    const uint32_t crc = Crc32c(t.data, t.length);
    if (crc != stored_crc) {
      char buf[96];
      std::snprintf(buf, sizeof(buf), "CRC32C mismatch: stored 0x%08x, computed 0x%08x", stored_crc,
                    crc);
      throw Error(buf);
    }
  } catch (const nlohmann::json::exception& ex) {
    throw Error(std::string("bad tensor entry: ") + ex.what(), context);
  } catch (const Error& ex) {
    throw Error(ex.message(), context);
  }
  return t;
}

}  // namespace

std::string DTypeName(DType dtype) {
  switch (dtype) {
    case DType::kFloat32:
      return "float32";
    case DType::kFloat64:
      return "float64";
    case DType::kFloat16:
      return "float16";
    case DType::kInt32:
      return "int32";
    case DType::kInt64:
      return "int64";
    case DType::kUInt8:
      return "uint8";
  }
  return "?";
}

size_t DTypeSize(DType dtype) {
  switch (dtype) {
    case DType::kFloat32:
      return 4;
    case DType::kFloat64:
      return 8;
    case DType::kFloat16:
      return 2;
    case DType::kInt32:
      return 4;
    case DType::kInt64:
      return 8;
    case DType::kUInt8:
      return 1;
  }
  return 0;
}

DType ParseDType(const std::string& name) {
  for (DType d : {DType::kFloat32, DType::kFloat64, DType::kFloat16, DType::kInt32, DType::kInt64,
                  DType::kUInt8}) {
    if (DTypeName(d) == name) return d;
  }
  throw Error("unknown dtype '" + name + "' (float32, float64, float16, int32, int64, uint8)");
}

int64_t ArchiveTensor::numel() const { return NumelOf(shape); }

std::string ShapeString(const std::vector<int64_t>& shape) {
  std::string s = "[";
  for (size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  return s + "]";
}

struct TensorArchiveReader::Mapping {
  explicit Mapping(const std::string& path) : file(path) {}
  MappedFile file;
};

TensorArchiveReader::TensorArchiveReader(std::string path) : path_(std::move(path)) {
  mapping_ = std::make_unique<Mapping>(path_);
  const uint8_t* p = mapping_->file.data();
  const uint64_t size = mapping_->file.size();
  const ErrorContext at_file{.file = path_};
  Check(size >= kPreambleSize,
        "too short for a tensor archive (" + std::to_string(size) + " bytes)", at_file);
  Check(std::memcmp(p, kTensorArchiveMagic.data(), 8) == 0,
        "not a wmkit tensor archive (magic is not WMTENSR1)", at_file);
  const uint64_t header_length = GetU64(p + 8);
  Check(header_length <= size - kPreambleSize,
        "header length " + std::to_string(header_length) + " runs past the end of the file (" +
            std::to_string(size) + " bytes; truncated?)",
        at_file);
  nlohmann::json header;
  try {
    header = nlohmann::json::parse(p + kPreambleSize, p + kPreambleSize + header_length);
  } catch (const nlohmann::json::exception& ex) {
    throw Error(std::string("header is not valid JSON: ") + ex.what(), at_file);
  }
  Check(header.is_object() && header.contains("format") && header["format"] == kTensorArchiveFormat,
        "header 'format' is not \"wmkit-tensors\"", {.file = path_, .key = "format"});
  Check(header.contains("version") && header["version"].is_number_integer(),
        "header lacks an integer 'version'", {.file = path_, .key = "version"});
  const int version = JsonInt<int>(header["version"]);
  Check(version == kTensorArchiveVersion,
        "unsupported archive version " + std::to_string(version) + " (this build reads 1)",
        {.file = path_, .key = "version"});
  Check(header.contains("data_length") && header["data_length"].is_number_unsigned(),
        "header lacks an unsigned 'data_length'", {.file = path_, .key = "data_length"});
  const uint64_t data_start = kPreambleSize + header_length;
  const uint64_t data_length = JsonInt<uint64_t>(header["data_length"]);
  Check(data_start % kTensorArchiveAlignment == 0,
        "data section does not start on a 64-byte boundary", {.file = path_, .key = "data_length"});
  Check(size - data_start == data_length,
        "file has " + std::to_string(size - data_start) + " data bytes, header says " +
            std::to_string(data_length) + " (truncated or appended to?)",
        {.file = path_, .key = "data_length"});
  Check(header.contains("tensors") && header["tensors"].is_object(),
        "header lacks a 'tensors' object", {.file = path_, .key = "tensors"});
  for (const auto& [name, entry] : header["tensors"].items()) {
    tensors_.emplace(
        name, ParseEntry(name, entry, p + data_start, data_length, {.file = path_, .key = name}));
  }
  meta_ = header.contains("meta") ? header["meta"] : nlohmann::json::object();
}

TensorArchiveReader::~TensorArchiveReader() = default;

std::vector<std::string> TensorArchiveReader::Names() const {
  std::vector<std::string> names;
  for (const auto& [name, t] : tensors_) names.push_back(name);
  return names;
}

const ArchiveTensor& TensorArchiveReader::Get(const std::string& name) const {
  auto it = tensors_.find(name);
  if (it == tensors_.end()) {
    throw Error("missing tensor (the archive has " + std::to_string(tensors_.size()) +
                    " tensors; list them with `python3 scripts/export_lpips_weights.py --list`)",
                {.file = path_, .key = name});
  }
  return it->second;
}

std::span<const float> TensorArchiveReader::Float32(const std::string& name,
                                                    const std::vector<int64_t>& shape) const {
  const ArchiveTensor& t = Get(name);
  const ErrorContext at{.file = path_, .key = name};
  Check(t.dtype == DType::kFloat32, "dtype is " + DTypeName(t.dtype) + ", expected float32", at);
  Check(t.shape == shape, "shape is " + ShapeString(t.shape) + ", expected " + ShapeString(shape),
        at);
  return {reinterpret_cast<const float*>(t.data), static_cast<size_t>(t.numel())};
}

void TensorArchiveWriter::Add(const std::string& name, DType dtype, std::vector<int64_t> shape,
                              const void* data, size_t bytes) {
  Check(!entries_.count(name), "duplicate tensor name", {.key = name});
  for (int64_t d : shape)
    Check(d >= 0, "negative dimension in " + ShapeString(shape), {.key = name});
  Check(bytes == static_cast<size_t>(NumelOf(shape)) * DTypeSize(dtype),
        std::to_string(bytes) + " bytes do not match shape " + ShapeString(shape) + " of " +
            DTypeName(dtype),
        {.key = name});
  entries_[name] = {dtype, std::move(shape), std::string(static_cast<const char*>(data), bytes)};
}

void TensorArchiveWriter::AddFloat32(const std::string& name, std::vector<int64_t> shape,
                                     const float* data) {
  const size_t bytes = static_cast<size_t>(NumelOf(shape)) * sizeof(float);
  Add(name, DType::kFloat32, std::move(shape), data, bytes);
}

void TensorArchiveWriter::Write(const std::string& path) const {
  nlohmann::json tensors = nlohmann::json::object();
  std::string data;
  for (const auto& [name, e] : entries_) {  // std::map: sorted names, reproducible bytes
    data.resize(AlignUp(data.size()), '\0');
    tensors[name] = {{"dtype", DTypeName(e.dtype)},
                     {"shape", e.shape},
                     {"offset", data.size()},
                     {"length", e.bytes.size()},
                     {"crc32c", Crc32c(e.bytes)}};
    data += e.bytes;
  }
  data.resize(AlignUp(data.size()), '\0');
  const nlohmann::json header = {{"format", kTensorArchiveFormat},
                                 {"version", kTensorArchiveVersion},
                                 {"data_length", data.size()},
                                 {"tensors", tensors},
                                 {"meta", meta_}};
  std::string text = header.dump();
  // Trailing spaces (valid JSON whitespace) put the data section on an aligned offset.
  text.resize(AlignUp(kPreambleSize + text.size()) - kPreambleSize, ' ');
  std::string preamble(kTensorArchiveMagic);
  PutU64(preamble, text.size());
  AtomicFileWriter out(path);
  out.Write(preamble);
  out.Write(text);
  out.Write(data);
  out.Commit();
}

}  // namespace wm

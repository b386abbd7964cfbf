#include "core/safetensors.h"

#include <algorithm>
#include <bit>
#include <set>
#include <utility>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/json_int.h"
#include "core/mapped_file.h"

namespace wm {
namespace {

static_assert(std::endian::native == std::endian::little,
              "safetensors data is little-endian and is viewed in place");

constexpr uint64_t kLengthFieldSize = 8;
// wmkit's dtypes and their safetensors codes (the spec's names for numpy's float32 ... uint8).
constexpr std::pair<DType, std::string_view> kDTypeCodes[] = {
    {DType::kFloat32, "F32"}, {DType::kFloat64, "F64"}, {DType::kFloat16, "F16"},
    {DType::kInt32, "I32"},   {DType::kInt64, "I64"},   {DType::kUInt8, "U8"}};

std::string Range(uint64_t begin, uint64_t end) {
  return "[" + std::to_string(begin) + ", " + std::to_string(end) + "]";
}

// numel(shape) * item_size, or an error when a damaged shape would overflow 64 bits.
uint64_t ExpectedBytes(const std::vector<int64_t>& shape, DType dtype) {
  uint64_t bytes = DTypeSize(dtype);
  for (int64_t d : shape) {
    Check(d >= 0, "negative dimension in shape " + ShapeString(shape));
    Check(!__builtin_mul_overflow(bytes, static_cast<uint64_t>(d), &bytes),
          "shape " + ShapeString(shape) + " overflows 64-bit sizes");
  }
  return bytes;
}

// nlohmann keeps the last of two equal keys; the spec forbids duplicates, so refuse them while
// parsing (depth 1 = the tensor names and "__metadata__").
nlohmann::json ParseHeaderJson(std::string_view text) {
  std::set<std::string> seen;
  auto reject_duplicates = [&seen](int depth, nlohmann::json::parse_event_t event,
                                   nlohmann::json& parsed) {
    if (depth == 1 && event == nlohmann::json::parse_event_t::key) {
      const std::string key = parsed.get<std::string>();
      Check(seen.insert(key).second, "duplicate header key '" + key + "'");
    }
    return true;
  };
  return nlohmann::json::parse(text.begin(), text.end(), reject_duplicates);
}

std::map<std::string, std::string> ParseMetadata(const nlohmann::json& j) {
  Check(j.is_object(), "__metadata__ is not a JSON object of strings");
  std::map<std::string, std::string> out;
  for (const auto& [key, value] : j.items()) {
    Check(value.is_string(), "__metadata__ value of '" + key + "' is not a string");
    out[key] = value.get<std::string>();
  }
  return out;
}

// One tensor entry, its offsets checked against the byte buffer.
SafetensorsTensor ParseEntry(const std::string& name, const nlohmann::json& e,
                             std::string_view buffer) {
  Check(e.is_object(), "tensor entry is not a JSON object");
  for (const char* field : {"dtype", "shape", "data_offsets"}) {
    Check(e.contains(field), std::string("tensor entry lacks field '") + field + "'");
  }
  Check(e.at("dtype").is_string(), "dtype is not a string");
  SafetensorsTensor t;
  t.name = name;
  t.dtype = ParseSafetensorsDType(e.at("dtype").get<std::string>());
  t.shape = JsonInts<int64_t>(e.at("shape"));
  const auto offsets = JsonInts<uint64_t>(e.at("data_offsets"));
  Check(offsets.size() == 2, "data_offsets must be [begin, end]");
  const uint64_t begin = offsets[0], end = offsets[1];
  Check(begin <= end, "data_offsets " + Range(begin, end) + " end before they begin");
  Check(end <= buffer.size(), "data_offsets " + Range(begin, end) +
                                  " lie outside the byte buffer of " +
                                  std::to_string(buffer.size()) + " bytes");
  const uint64_t expected = ExpectedBytes(t.shape, t.dtype);
  Check(end - begin == expected, "shape " + ShapeString(t.shape) + " of " +
                                     SafetensorsDTypeCode(t.dtype) + " needs " +
                                     std::to_string(expected) + " bytes, data_offsets " +
                                     Range(begin, end) + " hold " + std::to_string(end - begin));
  t.bytes = buffer.substr(begin, end - begin);
  return t;
}

// The spec requires the tensors to tile the buffer: no overlap, no hole, nothing after the last.
void CheckTiling(const std::map<std::string, SafetensorsTensor>& tensors, std::string_view buffer,
                 const ErrorContext& context) {
  std::vector<const SafetensorsTensor*> order;
  for (const auto& [name, t] : tensors) order.push_back(&t);
  auto begin_of = [&](const SafetensorsTensor* t) {
    return static_cast<uint64_t>(t->bytes.data() - buffer.data());
  };
  std::stable_sort(order.begin(), order.end(), [&](auto* a, auto* b) {
    return begin_of(a) != begin_of(b) ? begin_of(a) < begin_of(b)
                                      : a->bytes.size() < b->bytes.size();
  });
  uint64_t covered = 0;  // the buffer is tiled up to here
  for (const SafetensorsTensor* t : order) {
    ErrorContext at = context;
    at.key = t->name;
    const uint64_t begin = begin_of(t);
    Check(begin >= covered,
          "data_offsets " + Range(begin, begin + t->bytes.size()) +
              " overlap the previous tensor, which ends at " + std::to_string(covered),
          at);
    Check(begin == covered,
          "data_offsets " + Range(begin, begin + t->bytes.size()) +
              " leave a hole: the previous tensor ends at " + std::to_string(covered),
          at);
    covered = begin + t->bytes.size();
  }
  Check(covered == buffer.size(),
        "the byte buffer has " + std::to_string(buffer.size()) +
            " bytes but the tensors cover only " + std::to_string(covered),
        context);
}

uint64_t ReadLength(std::string_view file) {
  uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | static_cast<uint8_t>(file[i]);
  return v;
}

void PutLength(std::string& out, uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}

}  // namespace

std::string SafetensorsDTypeCode(DType dtype) {
  for (const auto& [d, code] : kDTypeCodes) {
    if (d == dtype) return std::string(code);
  }
  return "?";
}

DType ParseSafetensorsDType(const std::string& code) {
  for (const auto& [d, known] : kDTypeCodes) {
    if (known == code) return d;
  }
  throw Error("dtype '" + code + "' is not one wmkit holds (F32, F64, F16, I32, I64, U8)");
}

SafetensorsContents ParseSafetensors(std::string_view file, const std::string& path) {
  const ErrorContext context{.file = path};
  Check(file.size() >= kLengthFieldSize,
        "truncated: " + std::to_string(file.size()) + " bytes, expected an 8-byte header length",
        context);
  const uint64_t header_length = ReadLength(file);
  Check(header_length <= file.size() - kLengthFieldSize,
        "truncated header: length field says " + std::to_string(header_length) +
            " bytes, the file has " + std::to_string(file.size() - kLengthFieldSize) + " after it",
        context);
  Check(header_length <= kSafetensorsMaxHeaderBytes,
        "header of " + std::to_string(header_length) + " bytes exceeds the spec's 100 MB", context);
  const std::string_view text = file.substr(kLengthFieldSize, header_length);
  Check(!text.empty() && text.front() == '{', "header is not a JSON object (expected '{')",
        context);
  const std::string_view buffer = file.substr(kLengthFieldSize + header_length);
  SafetensorsContents out;
  std::string key;  // the entry being parsed, for the error
  try {
    const nlohmann::json header = ParseHeaderJson(text);
    for (const auto& [name, entry] : header.items()) {
      key = name;
      if (name == kSafetensorsMetadataKey) {
        out.metadata = ParseMetadata(entry);
      } else {
        out.tensors[name] = ParseEntry(name, entry, buffer);
      }
    }
  } catch (const nlohmann::json::exception& ex) {
    throw Error(std::string("bad header JSON: ") + ex.what(), {.file = path, .key = key});
  } catch (const Error& ex) {
    throw Error(ex.message(), {.file = path, .key = key});
  }
  CheckTiling(out.tensors, buffer, context);
  return out;
}

std::string SafetensorsHeader(const std::vector<SafetensorsTensor>& tensors,
                              const std::map<std::string, std::string>& metadata) {
  nlohmann::json header = nlohmann::json::object();
  if (!metadata.empty()) header[kSafetensorsMetadataKey] = metadata;
  uint64_t offset = 0;
  for (const SafetensorsTensor& t : tensors) {
    const ErrorContext context{.key = t.name};
    Check(!header.contains(t.name), "duplicate tensor name", context);
    Check(t.name != kSafetensorsMetadataKey, "a tensor may not be called __metadata__", context);
    Check(t.bytes.size() == ExpectedBytes(t.shape, t.dtype),
          "bytes do not match shape " + ShapeString(t.shape), context);
    header[t.name] = {{"dtype", SafetensorsDTypeCode(t.dtype)},
                      {"shape", t.shape},
                      {"data_offsets", {offset, offset + t.bytes.size()}}};
    offset += t.bytes.size();
  }
  std::string text = header.dump();
  text.append((kSafetensorsHeaderAlignment - text.size() % kSafetensorsHeaderAlignment) %
                  kSafetensorsHeaderAlignment,
              ' ');
  return text;
}

void WriteSafetensors(const std::string& path, std::vector<SafetensorsTensor> tensors,
                      const std::map<std::string, std::string>& metadata) {
  std::sort(tensors.begin(), tensors.end(), [](const auto& a, const auto& b) {
    const size_t size_a = DTypeSize(a.dtype), size_b = DTypeSize(b.dtype);
    return size_a != size_b ? size_a > size_b : a.name < b.name;
  });
  std::string header;
  try {
    header = SafetensorsHeader(tensors, metadata);
  } catch (const Error& ex) {
    throw ex.WithFile(path);
  }
  std::string length;
  PutLength(length, header.size());
  AtomicFileWriter out(path);
  out.Write(length);
  out.Write(header);
  for (const SafetensorsTensor& t : tensors) out.Write(t.bytes);
  out.Commit();
}

struct SafetensorsReader::Mapping {
  explicit Mapping(std::string path) : file(std::move(path)) {}
  MappedFile file;
};

SafetensorsReader::SafetensorsReader(const std::string& path)
    : mapping_(std::make_unique<Mapping>(path)),
      contents_(ParseSafetensors(mapping_->file.view(), path)) {}

SafetensorsReader::~SafetensorsReader() = default;

const std::string& SafetensorsReader::path() const { return mapping_->file.path(); }

}  // namespace wm

#include "ingest/parquet/encodings.h"

#include <cstring>

#include "core/error.h"

namespace wm::parquet {
namespace {

uint64_t ReadVarint(std::string_view bytes, size_t& pos) {
  uint64_t v = 0;
  for (int shift = 0; shift < 64 && pos < bytes.size(); shift += 7) {
    auto b = static_cast<uint8_t>(bytes[pos++]);
    v |= static_cast<uint64_t>(b & 0x7f) << shift;
    if ((b & 0x80) == 0) return v;
  }
  throw Error("RLE run header is truncated");
}

template <typename T>
T Load(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

}  // namespace

int BitWidth(uint32_t max_value) {
  int w = 0;
  while (max_value >> w) ++w;
  return w;
}

std::vector<uint32_t> DecodeRleHybrid(std::string_view bytes, int bit_width, int64_t count) {
  Check(bit_width >= 0 && bit_width <= 32, "bit width " + std::to_string(bit_width) + " > 32");
  Check(count >= 0, "negative value count");
  std::vector<uint32_t> out;
  out.reserve(static_cast<size_t>(std::min<int64_t>(count, 1 << 20)));
  size_t pos = 0;
  const uint64_t mask = bit_width == 32 ? 0xffffffffu : (1u << bit_width) - 1;
  while (static_cast<int64_t>(out.size()) < count) {
    Check(pos < bytes.size(), "RLE data ends after " + std::to_string(out.size()) + " of " +
                                  std::to_string(count) + " values");
    const uint64_t header = ReadVarint(bytes, pos);
    if (header & 1) {  // bit-packed: (header >> 1) groups of 8 values, LSB first
      const uint64_t groups = header >> 1;
      Check(groups <= (bytes.size() - pos) / std::max(bit_width, 1) + 1,
            "bit-packed run runs past the page");
      const uint64_t values = groups * 8;
      const uint64_t nbytes = groups * static_cast<uint64_t>(bit_width);
      Check(nbytes <= bytes.size() - pos, "bit-packed run runs past the page");
      const auto* p = reinterpret_cast<const uint8_t*>(bytes.data() + pos);
      for (uint64_t i = 0; i < values && static_cast<int64_t>(out.size()) < count; ++i) {
        uint64_t bit = i * bit_width, v = 0;
        for (int b = 0; b < bit_width; ++b, ++bit) v |= ((p[bit >> 3] >> (bit & 7)) & 1ull) << b;
        out.push_back(static_cast<uint32_t>(v & mask));
      }
      pos += nbytes;
    } else {  // RLE: (header >> 1) repeats of one value stored in ceil(width / 8) bytes
      const uint64_t repeats = header >> 1;
      const size_t width_bytes = (bit_width + 7) / 8;
      Check(width_bytes <= bytes.size() - pos, "RLE run value runs past the page");
      uint32_t v = 0;
      for (size_t b = 0; b < width_bytes; ++b)
        v |= static_cast<uint32_t>(static_cast<uint8_t>(bytes[pos + b])) << (8 * b);
      pos += width_bytes;
      Check(repeats > 0, "RLE run of length 0");
      const uint64_t n = std::min<uint64_t>(repeats, static_cast<uint64_t>(count) - out.size());
      out.insert(out.end(), n, v);
    }
  }
  return out;
}

// Appends `count` little-endian values stored as `Stored`; returns the bytes consumed.
template <typename Stored, typename Dst>
size_t AppendFixed(std::string_view bytes, PhysicalType type, int64_t count,
                   std::vector<Dst>& out) {
  Check(static_cast<uint64_t>(count) <= bytes.size() / sizeof(Stored),
        std::to_string(count) + " PLAIN " + TypeName(type) + " values need " +
            std::to_string(count * sizeof(Stored)) + " bytes, the page has " +
            std::to_string(bytes.size()));
  for (int64_t i = 0; i < count; ++i)
    out.push_back(Load<Stored>(bytes.data() + sizeof(Stored) * i));
  return static_cast<size_t>(count) * sizeof(Stored);
}

size_t DecodePlain(std::string_view bytes, PhysicalType type, int64_t count, Values& out) {
  Check(count >= 0, "negative value count");
  const char* p = bytes.data();
  switch (type) {
    case PhysicalType::kBoolean: {  // bit-packed, LSB first
      Check(static_cast<uint64_t>(count) <= bytes.size() * 8ull, "PLAIN BOOLEAN values truncated");
      for (int64_t i = 0; i < count; ++i) out.ints.push_back((p[i >> 3] >> (i & 7)) & 1);
      return static_cast<size_t>((count + 7) / 8);
    }
    case PhysicalType::kInt32:
      return AppendFixed<int32_t>(bytes, type, count, out.ints);
    case PhysicalType::kInt64:
      return AppendFixed<int64_t>(bytes, type, count, out.ints);
    case PhysicalType::kFloat:
      return AppendFixed<float>(bytes, type, count, out.reals);
    case PhysicalType::kDouble:
      return AppendFixed<double>(bytes, type, count, out.reals);
    case PhysicalType::kByteArray: {  // u32 length + bytes, each
      size_t pos = 0;
      for (int64_t i = 0; i < count; ++i) {
        Check(bytes.size() - pos >= 4,
              "PLAIN BYTE_ARRAY length truncated at value " + std::to_string(i));
        const uint32_t len = Load<uint32_t>(p + pos);
        pos += 4;
        Check(len <= bytes.size() - pos,
              "PLAIN BYTE_ARRAY value " + std::to_string(i) + " runs past the page");
        out.strings.emplace_back(p + pos, len);
        pos += len;
      }
      return pos;
    }
    default:
      break;
  }
  throw Error("physical type " + TypeName(type) + " is not supported");
}

void AppendFromDictionary(const Values& dict, const std::vector<uint32_t>& indices, Values& out) {
  const size_t n = dict.size();
  for (uint32_t i : indices) {
    Check(i < n, "dictionary index " + std::to_string(i) + " past the dictionary's " +
                     std::to_string(n) + " entries");
    if (!dict.ints.empty())
      out.ints.push_back(dict.ints[i]);
    else if (!dict.reals.empty())
      out.reals.push_back(dict.reals[i]);
    else
      out.strings.push_back(dict.strings[i]);
  }
}

}  // namespace wm::parquet

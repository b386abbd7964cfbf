#include "ingest/parquet/thrift_compact.h"

#include "core/error.h"

namespace wm::parquet {
namespace {

constexpr int kMaxDepth = 32;  // Parquet's own structs nest 4 deep; more is damage

int64_t ZigZag(uint64_t v) { return static_cast<int64_t>(v >> 1) ^ -static_cast<int64_t>(v & 1); }

ThriftType TypeOf(uint8_t nibble) {
  Check(nibble <= static_cast<uint8_t>(ThriftType::kStruct),
        "Thrift: unknown type id " + std::to_string(nibble));
  return static_cast<ThriftType>(nibble);
}

}  // namespace

uint8_t ThriftReader::ReadByte() {
  Check(pos_ < bytes_.size(), "Thrift: truncated at byte " + std::to_string(pos_));
  return static_cast<uint8_t>(bytes_[pos_++]);
}

uint64_t ThriftReader::ReadVarint() {
  uint64_t v = 0;
  for (int shift = 0; shift < 64; shift += 7) {
    uint8_t b = ReadByte();
    v |= static_cast<uint64_t>(b & 0x7f) << shift;
    if ((b & 0x80) == 0) return v;
  }
  throw Error("Thrift: varint longer than 10 bytes at byte " + std::to_string(pos_));
}

void ThriftReader::ReadStruct(const std::function<void(int16_t, ThriftType)>& on_field) {
  Check(++depth_ <= kMaxDepth, "Thrift: structs nested deeper than " + std::to_string(kMaxDepth));
  int16_t id = 0;
  while (true) {
    uint8_t header = ReadByte();
    ThriftType type = TypeOf(header & 0x0f);
    if (type == ThriftType::kStop) break;
    const int delta = header >> 4;
    id = delta != 0 ? static_cast<int16_t>(id + delta) : static_cast<int16_t>(ZigZag(ReadVarint()));
    on_field(id, type);
  }
  --depth_;
}

int64_t ThriftReader::ReadInt(ThriftType type) {
  switch (type) {
    case ThriftType::kByte:
      return static_cast<int8_t>(ReadByte());
    case ThriftType::kI16:
    case ThriftType::kI32:
    case ThriftType::kI64:
      return ZigZag(ReadVarint());
    default:
      throw Error("Thrift: expected an integer, found type " +
                  std::to_string(static_cast<int>(type)));
  }
}

bool ThriftReader::ReadBool(ThriftType type) {
  Check(type == ThriftType::kTrue || type == ThriftType::kFalse,
        "Thrift: expected a bool, found type " + std::to_string(static_cast<int>(type)));
  return type == ThriftType::kTrue;
}

std::string ThriftReader::ReadBinary() {
  uint64_t n = ReadVarint();
  Check(n <= bytes_.size() - pos_, "Thrift: binary of " + std::to_string(n) +
                                       " bytes runs past the end at byte " + std::to_string(pos_));
  std::string out(bytes_.substr(pos_, n));
  pos_ += n;
  return out;
}

ThriftList ThriftReader::ReadListHeader() {
  uint8_t header = ReadByte();
  ThriftList list{TypeOf(header & 0x0f), header >> 4};
  if (list.size == 15) list.size = static_cast<int64_t>(ReadVarint() & 0x7fffffff);
  // Every element takes at least one byte, so a larger count is damage (and would loop long).
  Check(static_cast<uint64_t>(list.size) <= bytes_.size() - pos_,
        "Thrift: list of " + std::to_string(list.size) + " elements runs past the end");
  return list;
}

void ThriftReader::SkipElement(ThriftType type) {
  // Inside lists and maps a bool is one byte, not a type nibble.
  if (type == ThriftType::kTrue || type == ThriftType::kFalse)
    ReadByte();
  else
    Skip(type);
}

void ThriftReader::Skip(ThriftType type) {
  switch (type) {
    case ThriftType::kTrue:
    case ThriftType::kFalse:
      return;  // the value was the field header's type nibble
    case ThriftType::kByte:
      ReadByte();
      return;
    case ThriftType::kI16:
    case ThriftType::kI32:
    case ThriftType::kI64:
      ReadVarint();
      return;
    case ThriftType::kDouble:
      Check(bytes_.size() - pos_ >= 8, "Thrift: truncated double");
      pos_ += 8;
      return;
    case ThriftType::kBinary:
      ReadBinary();
      return;
    case ThriftType::kList:
    case ThriftType::kSet: {
      Check(++depth_ <= kMaxDepth, "Thrift: lists nested too deep");
      ThriftList list = ReadListHeader();
      for (int64_t i = 0; i < list.size; ++i) SkipElement(list.element);
      --depth_;
      return;
    }
    case ThriftType::kMap: {
      uint64_t n = ReadVarint();
      if (n == 0) return;
      uint8_t kv = ReadByte();
      Check(n <= bytes_.size() - pos_, "Thrift: map runs past the end");
      for (uint64_t i = 0; i < n; ++i) {
        SkipElement(TypeOf(kv >> 4));
        SkipElement(TypeOf(kv & 0x0f));
      }
      return;
    }
    case ThriftType::kStruct:
      ReadStruct([this](int16_t, ThriftType t) { Skip(t); });
      return;
    case ThriftType::kStop:
      break;
  }
  throw Error("Thrift: cannot skip type " + std::to_string(static_cast<int>(type)));
}

}  // namespace wm::parquet

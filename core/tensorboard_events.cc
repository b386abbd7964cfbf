#include "core/tensorboard_events.h"

#include <bit>
#include <chrono>
#include <cstring>
#include <string_view>

#include "core/error.h"

namespace wm {
namespace {

static_assert(std::endian::native == std::endian::little,
              "protobuf fixed fields are little-endian");

// Protobuf wire types.
constexpr int kVarint = 0, kFixed64 = 1, kLengthDelimited = 2, kFixed32 = 5;

void PutVarint(std::string& out, uint64_t v) {
  while (v >= 0x80) {
    out.push_back(static_cast<char>((v & 0x7f) | 0x80));
    v >>= 7;
  }
  out.push_back(static_cast<char>(v));
}

void PutKey(std::string& out, int field, int wire_type) {
  PutVarint(out, static_cast<uint64_t>(field) << 3 | wire_type);
}

template <class T>
void PutFixed(std::string& out, int field, T value) {
  static_assert(sizeof(T) == 4 || sizeof(T) == 8);
  PutKey(out, field, sizeof(T) == 8 ? kFixed64 : kFixed32);
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out.append(bytes, sizeof(T));
}

void PutBytes(std::string& out, int field, std::string_view bytes) {
  PutKey(out, field, kLengthDelimited);
  PutVarint(out, bytes.size());
  out.append(bytes);
}

// Event fields (event.proto), Summary (summary.proto) and Summary.Value fields.
constexpr int kEventFieldWallTime = 1, kEventFieldStep = 2, kEventFieldFileVersion = 3,
              kEventFieldSummary = 5;
constexpr int kSummaryFieldValue = 1;
constexpr int kValueFieldTag = 1, kValueFieldSimpleValue = 2, kValueFieldImage = 4;
constexpr int kImageFieldHeight = 1, kImageFieldWidth = 2, kImageFieldColorspace = 3,
              kImageFieldEncoded = 4;

void PutVarintField(std::string& out, int field, uint64_t value) {
  PutKey(out, field, kVarint);
  PutVarint(out, value);  // int32/int64 negatives: two's complement, as protobuf does
}

// Event{wall_time, step, summary}: what a scalars or an image event holds.
std::string SummaryEvent(double wall_time, int64_t step, const std::string& summary) {
  std::string event;
  PutFixed(event, kEventFieldWallTime, wall_time);
  PutVarintField(event, kEventFieldStep, static_cast<uint64_t>(step));
  PutBytes(event, kEventFieldSummary, summary);
  return event;
}

// Reads a varint at `pos` of `bytes`, advancing `pos`; throws on a truncated one.
uint64_t GetVarint(std::string_view bytes, size_t& pos) {
  uint64_t value = 0;
  for (int shift = 0; shift < 64; shift += 7) {
    Check(pos < bytes.size(), "truncated protobuf varint");
    const auto b = static_cast<uint8_t>(bytes[pos++]);
    value |= static_cast<uint64_t>(b & 0x7f) << shift;
    if (b < 0x80) return value;
  }
  throw Error("protobuf varint longer than 10 bytes");
}

}  // namespace

std::string EncodeFileVersionEvent(double wall_time) {
  std::string event;
  PutFixed(event, kEventFieldWallTime, wall_time);
  PutBytes(event, kEventFieldFileVersion, kEventFileVersion);
  return event;
}

std::string EncodeScalarsEvent(double wall_time, int64_t step,
                               const std::vector<ScalarSummary>& values) {
  std::string summary;
  for (const ScalarSummary& v : values) {
    std::string value;
    PutBytes(value, kValueFieldTag, v.tag);
    PutFixed(value, kValueFieldSimpleValue, v.value);
    PutBytes(summary, kSummaryFieldValue, value);
  }
  return SummaryEvent(wall_time, step, summary);
}

std::string EncodeImageEvent(double wall_time, int64_t step, const ImageSummary& image) {
  std::string fields;
  PutVarintField(fields, kImageFieldHeight, static_cast<uint64_t>(image.height));
  PutVarintField(fields, kImageFieldWidth, static_cast<uint64_t>(image.width));
  PutVarintField(fields, kImageFieldColorspace, static_cast<uint64_t>(image.channels));
  PutBytes(fields, kImageFieldEncoded, image.png);
  std::string value;
  PutBytes(value, kValueFieldTag, image.tag);
  PutBytes(value, kValueFieldImage, fields);
  std::string summary;
  PutBytes(summary, kSummaryFieldValue, value);
  return SummaryEvent(wall_time, step, summary);
}

int64_t DecodeEventStep(std::string_view event) {
  int64_t step = 0;
  size_t pos = 0;
  while (pos < event.size()) {
    const uint64_t key = GetVarint(event, pos);
    switch (key & 7) {
      case kVarint: {
        const uint64_t v = GetVarint(event, pos);
        if (key >> 3 == kEventFieldStep) step = static_cast<int64_t>(v);
        break;
      }
      case kFixed64:
        pos += 8;
        break;
      case kFixed32:
        pos += 4;
        break;
      case kLengthDelimited:
        pos += GetVarint(event, pos);
        break;
      default:
        throw Error("unsupported protobuf wire type " + std::to_string(key & 7));
    }
  }
  Check(pos == event.size(), "protobuf field runs past the end of the event");
  return step;
}

double EventWallTime() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace wm

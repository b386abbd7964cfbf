#include "core/tensorboard_events.h"

#include <bit>
#include <chrono>
#include <cstring>
#include <string_view>

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
constexpr int kValueFieldTag = 1, kValueFieldSimpleValue = 2;

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
  std::string event;
  PutFixed(event, kEventFieldWallTime, wall_time);
  PutKey(event, kEventFieldStep, kVarint);
  PutVarint(event, static_cast<uint64_t>(step));  // int64: two's complement, as protobuf does
  PutBytes(event, kEventFieldSummary, summary);
  return event;
}

double EventWallTime() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace wm

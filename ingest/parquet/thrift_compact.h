#pragma once
// A reader of the Thrift compact protocol, the encoding of Parquet's footer (FileMetaData) and
// page headers. Only what Parquet uses: structs, lists, binaries and integers; unknown fields
// are skipped, so newer writers' additions are harmless. Spec:
// https://github.com/apache/thrift/blob/master/doc/specs/thrift-compact-protocol.md
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

namespace wm::parquet {

// Compact-protocol type ids (the low nibble of a field header).
enum class ThriftType : uint8_t {
  kStop = 0,
  kTrue = 1,
  kFalse = 2,
  kByte = 3,
  kI16 = 4,
  kI32 = 5,
  kI64 = 6,
  kDouble = 7,
  kBinary = 8,
  kList = 9,
  kSet = 10,
  kMap = 11,
  kStruct = 12,
};

struct ThriftList {
  ThriftType element;
  int64_t size;
};

class ThriftReader {
 public:
  explicit ThriftReader(std::string_view bytes) : bytes_(bytes) {}

  // Calls on_field(id, type) for every field of the struct at the cursor, up to its stop byte.
  // The callback must consume the field's value (a Read* call or Skip(type)).
  void ReadStruct(const std::function<void(int16_t id, ThriftType type)>& on_field);

  int64_t ReadInt(ThriftType type);  // byte, i16, i32 or i64 (zigzag varints)
  bool ReadBool(ThriftType type);    // a field's bool lives in its type nibble
  std::string ReadBinary();
  ThriftList ReadListHeader();
  void Skip(ThriftType type);

  size_t position() const { return pos_; }

 private:
  uint8_t ReadByte();
  uint64_t ReadVarint();
  void SkipElement(ThriftType type);
  std::string_view bytes_;
  size_t pos_ = 0;
  int depth_ = 0;  // nesting of structs/lists, bounded so damaged bytes cannot recurse deeply
};

}  // namespace wm::parquet

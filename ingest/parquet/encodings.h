#pragma once
// Parquet's value and level encodings: the RLE / bit-packed hybrid (levels, dictionary indices,
// v2 booleans) and PLAIN. Spec: https://parquet.apache.org/docs/file-format/data-pages/encodings/
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "ingest/parquet/metadata.h"

namespace wm::parquet {

// Decodes `count` values of `bit_width` bits (0..32) from RLE / bit-packed hybrid runs.
// Throws wm::Error when the runs end early.
std::vector<uint32_t> DecodeRleHybrid(std::string_view bytes, int bit_width, int64_t count);

// Bits needed for values 0..max_value (Parquet's level width).
int BitWidth(uint32_t max_value);

// Decoded values of one column, one vector per kind of physical type.
struct Values {
  std::vector<int64_t> ints;         // BOOLEAN (0/1), INT32, INT64
  std::vector<double> reals;         // FLOAT, DOUBLE
  std::vector<std::string> strings;  // BYTE_ARRAY
  size_t size() const { return ints.size() + reals.size() + strings.size(); }
};

// Appends `count` PLAIN-encoded values of `type` from `bytes`; returns the bytes consumed.
size_t DecodePlain(std::string_view bytes, PhysicalType type, int64_t count, Values& out);

// Appends dictionary[indices[i]] for each index; throws on an index past the dictionary.
void AppendFromDictionary(const Values& dictionary, const std::vector<uint32_t>& indices,
                          Values& out);

}  // namespace wm::parquet

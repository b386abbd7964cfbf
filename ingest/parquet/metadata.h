#pragma once
// The parts of Parquet's Thrift metadata (parquet.thrift) that reading values needs: the file
// footer (schema, row groups, column chunks) and page headers. Field numbers are parquet.thrift's.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace wm::parquet {

enum class PhysicalType : int32_t {
  kBoolean = 0,
  kInt32 = 1,
  kInt64 = 2,
  kInt96 = 3,
  kFloat = 4,
  kDouble = 5,
  kByteArray = 6,
  kFixedLenByteArray = 7,
};
enum class Repetition : int32_t { kRequired = 0, kOptional = 1, kRepeated = 2 };
enum class Codec : int32_t { kUncompressed = 0, kSnappy = 1, kGzip = 2, kZstd = 6 };
enum class Encoding : int32_t { kPlain = 0, kPlainDictionary = 2, kRle = 3, kRleDictionary = 8 };
enum class PageType : int32_t { kData = 0, kIndex = 1, kDictionary = 2, kDataV2 = 3 };

std::string TypeName(PhysicalType type);
std::string CodecName(int32_t codec);
std::string EncodingName(int32_t encoding);

struct SchemaElement {
  std::string name;
  bool has_type = false;  // leaves have a physical type, groups have children
  PhysicalType type = PhysicalType::kInt32;
  Repetition repetition = Repetition::kRequired;
  int32_t num_children = 0;
};

struct ColumnChunk {
  std::vector<std::string> path;  // path_in_schema, e.g. {"action", "list", "element"}
  PhysicalType type = PhysicalType::kInt32;
  int32_t codec = 0;
  int64_t num_values = 0;  // level entries, nulls included
  int64_t data_page_offset = 0;
  int64_t dictionary_page_offset = -1;  // -1: none
  int64_t total_compressed_size = 0;
};

struct RowGroup {
  int64_t num_rows = 0;
  std::vector<ColumnChunk> columns;
};

struct FileMetaData {
  int64_t num_rows = 0;
  std::vector<SchemaElement> schema;  // depth-first, the root first
  std::vector<RowGroup> row_groups;
  std::string created_by;
};

struct PageHeader {
  PageType type = PageType::kData;
  int32_t uncompressed_size = 0, compressed_size = 0;
  int32_t num_values = 0;  // level entries (data pages) or dictionary entries
  int32_t encoding = 0;
  // Data page v1: how levels are encoded (RLE; BIT_PACKED is deprecated and refused).
  int32_t definition_level_encoding = 3, repetition_level_encoding = 3;
  // Data page v2: level byte lengths (stored uncompressed ahead of the values).
  int32_t definition_levels_length = 0, repetition_levels_length = 0;
  bool is_compressed = true;
  size_t header_size = 0;  // bytes the Thrift header itself took
};

// Parses the footer's Thrift bytes. Throws wm::Error (without file context; callers add it).
FileMetaData ParseFileMetaData(std::string_view thrift);
// Parses the page header at the start of `bytes`.
PageHeader ParsePageHeader(std::string_view bytes);

}  // namespace wm::parquet

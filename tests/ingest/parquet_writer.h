#pragma once
// A tiny Parquet writer for tests and fuzz seeds: the caller assembles pages from the pieces
// below (encodings, page headers), this writes the Thrift compact footer and the file around
// them. It writes what the reader must accept, including encodings the LeRobot sample does not
// use (dictionary pages, data pages v2, optional scalars, null and empty lists).
#include <cstdint>
#include <string>
#include <vector>

#include "ingest/parquet/metadata.h"

namespace wm::parquet::testing {

// --- encodings
std::string Varint(uint64_t v);
std::string RleRun(uint32_t value, uint64_t count, int bit_width);             // one RLE run
std::string BitPackedRun(const std::vector<uint32_t>& values, int bit_width);  // padded to 8
std::string LengthBytes(size_t size);                                          // little-endian u32
std::string WithLength(const std::string& bytes);  // u32 length prefix (v1 levels)
std::string PlainInt64(const std::vector<int64_t>& v);
std::string PlainFloat(const std::vector<float>& v);
std::string PlainDouble(const std::vector<double>& v);
std::string Snappy(const std::string& raw);

// --- pages: header + payload. `raw_size` is the payload's size before compression.
struct PageSpec {
  PageType type = PageType::kData;
  int32_t num_values = 0;
  Encoding encoding = Encoding::kPlain;
  int32_t raw_size = 0;
  // data page v2 only
  int32_t num_nulls = 0, num_rows = 0, definition_bytes = 0, repetition_bytes = 0;
  bool is_compressed = true;
};
std::string Page(const PageSpec& spec, const std::string& payload);

// --- file
struct LeafSpec {
  std::vector<SchemaElement> elements;  // the field's schema elements, depth-first
  std::vector<std::string> path;        // path_in_schema of its one leaf
  PhysicalType type;
};
struct ChunkSpec {
  std::string pages;  // concatenated Page()s
  int64_t num_values = 0;
  int32_t codec = 0;
  bool dictionary_first = false;  // the first page is a dictionary page
};
// One row group per entry of `row_groups` (each holds one chunk per leaf, in order).
std::string ParquetFileBytes(
    const std::vector<LeafSpec>& leaves,
    const std::vector<std::pair<int64_t, std::vector<ChunkSpec>>>& row_groups);

// Schema helpers: a scalar field, and pyarrow's 3-level list<element>.
LeafSpec ScalarLeaf(const std::string& name, PhysicalType type, Repetition repetition);
LeafSpec ListLeaf(const std::string& name, PhysicalType type);

// Ready-made files (tests and fuzz seeds): column "reward", and column "action" holding
// [1,2,3], [], null, [4] in row group 0 and [5,6] over two v1 pages in row group 1 (with
// `null_element`, the 3 is a null element instead).
std::string OptionalDictionaryFile();
std::string ListColumnFile(bool null_element = false);

}  // namespace wm::parquet::testing

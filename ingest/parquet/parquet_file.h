#pragma once
// A small Parquet reader: what pyarrow / pandas write for LeRobot datasets. Flat and optional
// columns of BOOLEAN, INT32, INT64, FLOAT, DOUBLE and BYTE_ARRAY, and one level of lists
// (`list<float>`); PLAIN and dictionary (RLE / bit-packed) encodings; data pages v1 and v2;
// UNCOMPRESSED, SNAPPY and ZSTD. The format: https://parquet.apache.org/docs/file-format/
// Errors are wm::Error naming the file, the row group, the column and the page.
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "ingest/parquet/encodings.h"
#include "ingest/parquet/metadata.h"

namespace wm {
class MappedFile;
}

namespace wm::parquet {

// A leaf of the schema: one column chunk per row group.
struct LeafColumn {
  std::string path;   // dotted path_in_schema, e.g. "action.list.element"
  std::string field;  // its top-level field, e.g. "action"
  PhysicalType type = PhysicalType::kInt32;
  int max_definition = 0, max_repetition = 0;
  // For a list: the definition level at which an element slot exists (below it the list is
  // null or empty).
  int element_definition = 0;
};

// All rows of one column. Row r holds values [row_starts[r], row_starts[r + 1]): one for a
// present scalar, none for a null scalar or a null / empty list, n for a list of n.
struct Column {
  std::string path;
  PhysicalType type = PhysicalType::kInt32;
  Values values;  // the vector matching `type` is filled
  std::vector<int64_t> row_starts{0};
  int64_t rows() const { return static_cast<int64_t>(row_starts.size()) - 1; }
  int64_t RowSize(int64_t r) const { return row_starts[r + 1] - row_starts[r]; }
};

class ParquetFile {
 public:
  // Maps and checks the file: magic at both ends, footer length, schema. Throws wm::Error.
  explicit ParquetFile(const std::string& path);
  // The same over bytes held in memory (tests, fuzzing); `name` stands for the file in errors.
  static ParquetFile FromBytes(std::string bytes, const std::string& name);
  ~ParquetFile();
  ParquetFile(ParquetFile&&) noexcept;

  const std::string& name() const { return name_; }
  int64_t num_rows() const { return meta_.num_rows; }
  size_t num_row_groups() const { return meta_.row_groups.size(); }
  const std::vector<LeafColumn>& leaves() const { return leaves_; }
  const FileMetaData& metadata() const { return meta_; }
  // The leaf named `name` (a top-level field such as "action" or a dotted path); nullptr if none.
  const LeafColumn* Find(const std::string& name) const;

  // Reads and decodes a column across all row groups. Throws if the column does not exist.
  Column Read(const std::string& name) const;
  // The same over the row groups [first, end) only (a LeRobot v3.0 episode is a few row groups
  // of a large file); the Column's row 0 is row GroupStart(first) of the file.
  Column Read(const std::string& name, size_t first, size_t end) const;
  // The file row at which row group `g` starts (num_rows() for g = num_row_groups()).
  int64_t GroupStart(size_t g) const;

 private:
  ParquetFile(std::string name, std::unique_ptr<MappedFile> mapped, std::string owned);
  void ParseFooter();
  void ReadChunk(const LeafColumn& leaf, size_t row_group, Column& out) const;

  std::string name_;
  std::unique_ptr<MappedFile> mapped_;
  std::string owned_;
  std::string_view bytes_;
  FileMetaData meta_;
  std::vector<LeafColumn> leaves_;
};

}  // namespace wm::parquet

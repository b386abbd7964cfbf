#pragma once
// Whole Parquet columns as plain vectors, as the LeRobot readers use them: per-step columns of
// data/*.parquet and the per-episode columns of v3.0's meta/*.parquet.
#include <cstdint>
#include <string>
#include <vector>

#include "ingest/parquet/parquet_file.h"

namespace wm::ingest {

// A numeric column as doubles, `width` values per row (ints converted). Throws wm::Error naming
// the file, column and row when a row holds another number of values or the column is text.
std::vector<double> NumberColumn(const parquet::ParquetFile& file, const std::string& key,
                                 int64_t width);
// A text column, one string per row; a null row is an error.
std::vector<std::string> TextColumn(const parquet::ParquetFile& file, const std::string& key);

}  // namespace wm::ingest

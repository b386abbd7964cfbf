#pragma once
// Whole Parquet columns as plain vectors, as the LeRobot readers use them: per-step columns of
// data/*.parquet and the per-episode columns of v3.0's meta/*.parquet.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/error.h"
#include "ingest/parquet/parquet_file.h"

namespace wm::ingest {

// A numeric column as doubles, `width` values per row (ints converted), of the row groups
// [first_group, end_group) (default: all). Throws wm::Error naming the file, column and row when a
// row holds another number of values or the column is text.
std::vector<double> NumberColumn(const parquet::ParquetFile& file, const std::string& key,
                                 int64_t width, size_t first_group = 0,
                                 size_t end_group = SIZE_MAX);
// A value of NumberColumn as the integer it stands for; throws wm::Error (with `where`) when it is
// fractional, NaN or beyond +-2^53, where doubles stop holding every integer (casting such a
// double would be undefined behaviour).
int64_t WholeNumber(double v, const ErrorContext& where = {});
// "12" for a whole number, "1e+300" / "0.5" otherwise: a value for an error message.
std::string NumberText(double v);

// A text column, one string per row; a null row is an error.
std::vector<std::string> TextColumn(const parquet::ParquetFile& file, const std::string& key);

}  // namespace wm::ingest

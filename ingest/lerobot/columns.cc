#include "ingest/lerobot/columns.h"

#include <cmath>
#include <sstream>

#include "core/error.h"

namespace wm::ingest {
namespace {

parquet::Column ReadRows(const parquet::ParquetFile& file, const std::string& key, int64_t width,
                         size_t first_group = 0, size_t end_group = SIZE_MAX) {
  parquet::Column c = file.Read(key, first_group, end_group);
  const int64_t first_row = file.GroupStart(first_group);
  for (int64_t r = 0; r < c.rows(); ++r) {
    Check(c.RowSize(r) == width,
          "row " + std::to_string(first_row + r) + " holds " + std::to_string(c.RowSize(r)) +
              " values, expected " + std::to_string(width),
          {.file = file.name(), .key = key});
  }
  return c;
}

}  // namespace

std::vector<double> NumberColumn(const parquet::ParquetFile& file, const std::string& key,
                                 int64_t width, size_t first_group, size_t end_group) {
  parquet::Column c = ReadRows(file, key, width, first_group, end_group);
  if (!c.values.reals.empty() || c.values.size() == 0) return c.values.reals;
  Check(c.values.strings.empty(), "expected numbers, found strings",
        {.file = file.name(), .key = key});
  return {c.values.ints.begin(), c.values.ints.end()};
}

int64_t WholeNumber(double v, const ErrorContext& where) {
  constexpr double kExact = 9007199254740992.0;  // 2^53
  Check(v >= -kExact && v <= kExact && v == std::floor(v),
        "expected an integer, found " + NumberText(v), where);
  return static_cast<int64_t>(v);
}

std::string NumberText(double v) {
  if (std::abs(v) <= 9007199254740992.0 && v == std::floor(v)) {
    return std::to_string(static_cast<int64_t>(v));
  }
  std::ostringstream s;
  s << v;
  return s.str();
}

std::vector<std::string> TextColumn(const parquet::ParquetFile& file, const std::string& key) {
  parquet::Column c = ReadRows(file, key, 1);
  Check(c.values.strings.size() == static_cast<size_t>(c.rows()), "expected text, found numbers",
        {.file = file.name(), .key = key});
  return c.values.strings;
}

}  // namespace wm::ingest

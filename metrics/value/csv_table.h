#pragma once
// CsvTable: a small CSV file with a header row, read whole, for the metric tools' tabular inputs
// (per-episode returns, scaling points), and two helpers that write CSV cells. Columns are found
// by header name, so any column order works. Every error names the file, the 1-based line and
// the column, e.g.
//   returns.csv: line 7: column 'real_return': 'n/a' is not a number
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace wm {
class Error;
}

namespace wm::metrics {

class CsvTable {
 public:
  // Comma-separated; a cell may be double-quoted ("a,b", "say ""hi"""), quoted cells do not
  // span lines. Cells are trimmed of spaces and tabs; CRLF line ends and a UTF-8 byte-order mark
  // are accepted; blank lines are skipped. Throws wm::Error for an unreadable or empty file, a
  // header without names or with a repeated name, and a row whose cell count differs from the
  // header's.
  static CsvTable Read(const std::string& path);

  // Same rules, from text in memory; `path` only names the source in errors.
  static CsvTable Parse(const std::string& text, const std::string& path);

  const std::string& path() const { return path_; }
  const std::vector<std::string>& header() const { return header_; }
  size_t rows() const { return cells_.size(); }
  int64_t line(size_t row) const { return lines_[row]; }  // 1-based line in the file

  // The index of column `name`, or nullopt.
  std::optional<size_t> FindColumn(const std::string& name) const;
  // The index of column `name`; throws wm::Error listing the header when it is missing.
  size_t Column(const std::string& name) const;

  const std::string& Cell(size_t row, size_t column) const { return cells_[row][column]; }
  // The cell as a finite double; throws wm::Error (file, line, column) when it is empty, not a
  // number, or NaN / infinite.
  double Number(size_t row, size_t column) const;
  // The cell as text; throws wm::Error (file, line, column) when it is empty.
  const std::string& NonEmpty(size_t row, size_t column) const;

  // `error` thrown by code that counted this table's rows from 0 (ErrorContext::record), as an
  // error naming this file and, when it names a row, that row's line.
  Error AtLine(const Error& error) const;

 private:
  std::string path_;
  std::vector<std::string> header_;
  int64_t header_line_ = 0;
  std::vector<std::vector<std::string>> cells_;
  std::vector<int64_t> lines_;
};

// Writing: `text` as one CSV cell, double-quoted (inner quotes doubled) when it holds a comma, a
// quote or a line break; a finite number in its shortest round-trip form, "" for NaN/infinity.
std::string CsvCell(const std::string& text);
std::string CsvNumber(double value);

}  // namespace wm::metrics

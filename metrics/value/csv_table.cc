#include "metrics/value/csv_table.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "core/error.h"

namespace wm::metrics {
namespace {

std::string Trim(const std::string& s) {
  const size_t begin = s.find_first_not_of(" \t");
  if (begin == std::string::npos) return "";
  return s.substr(begin, s.find_last_not_of(" \t") - begin + 1);
}

// Splits one line into cells; `"` opens a quoted cell in which `""` is a literal quote.
std::vector<std::string> SplitLine(const std::string& line, const ErrorContext& where) {
  std::vector<std::string> cells;
  std::string cell;
  bool quoted = false, was_quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char ch = line[i];
    if (quoted) {
      if (ch != '"') {
        cell += ch;
      } else if (i + 1 < line.size() && line[i + 1] == '"') {
        cell += '"', ++i;
      } else {
        quoted = false;
      }
    } else if (ch == '"' && Trim(cell).empty()) {
      quoted = was_quoted = true;
      cell.clear();
    } else if (ch == ',') {
      cells.push_back(was_quoted ? cell : Trim(cell));
      cell.clear();
      was_quoted = false;
    } else {
      cell += ch;
    }
  }
  Check(!quoted, "unterminated quoted cell", where);
  cells.push_back(was_quoted ? cell : Trim(cell));
  return cells;
}

ErrorContext LineContext(const std::string& path, int64_t line) {
  return {.file = path, .record = line, .record_label = "line"};
}

}  // namespace

CsvTable CsvTable::Read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  Check(in.good(), "cannot open the file", {.file = path});
  std::ostringstream text;
  text << in.rdbuf();
  Check(!in.bad(), "read error", {.file = path});
  return Parse(text.str(), path);
}

CsvTable CsvTable::Parse(const std::string& text, const std::string& path) {
  CsvTable table;
  table.path_ = path;
  std::istringstream in(text.rfind("\xEF\xBB\xBF", 0) == 0 ? text.substr(3) : text);
  std::string line;
  for (int64_t number = 1; std::getline(in, line); ++number) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (Trim(line).empty()) continue;
    const ErrorContext where = LineContext(path, number);
    std::vector<std::string> cells = SplitLine(line, where);
    if (table.header_.empty()) {
      std::set<std::string> seen;
      for (const auto& name : cells) {
        Check(!name.empty(), "the header has an empty column name", where);
        Check(seen.insert(name).second, "the header repeats column '" + name + "'", where);
      }
      table.header_ = std::move(cells);
      table.header_line_ = number;
      continue;
    }
    Check(cells.size() == table.header_.size(),
          std::to_string(cells.size()) + " cells, but the header has " +
              std::to_string(table.header_.size()) + " columns",
          where);
    table.cells_.push_back(std::move(cells));
    table.lines_.push_back(number);
  }
  Check(!table.header_.empty(), "empty file: expected a header row", {.file = path});
  return table;
}

std::optional<size_t> CsvTable::FindColumn(const std::string& name) const {
  for (size_t i = 0; i < header_.size(); ++i) {
    if (header_[i] == name) return i;
  }
  return std::nullopt;
}

size_t CsvTable::Column(const std::string& name) const {
  if (auto index = FindColumn(name)) return *index;
  std::string names;
  for (const auto& h : header_) names += (names.empty() ? "" : ", ") + h;
  throw Error("missing column '" + name + "' (the header has: " + names + ")",
              LineContext(path_, header_line_));
}

const std::string& CsvTable::NonEmpty(size_t row, size_t column) const {
  const std::string& cell = cells_[row][column];
  Check(!cell.empty(), "column '" + header_[column] + "': empty cell",
        LineContext(path_, lines_[row]));
  return cell;
}

double CsvTable::Number(size_t row, size_t column) const {
  const std::string& cell = NonEmpty(row, column);
  // from_chars does not take a leading '+', which spreadsheets sometimes write.
  const size_t skip = cell[0] == '+' ? 1 : 0;
  double value = 0;
  auto [end, error] = std::from_chars(cell.data() + skip, cell.data() + cell.size(), value);
  const std::string prefix = "column '" + header_[column] + "': '" + cell + "' ";
  const ErrorContext where = LineContext(path_, lines_[row]);
  Check(error != std::errc::invalid_argument && end == cell.data() + cell.size(),
        prefix + "is not a number", where);
  Check(error == std::errc() && std::isfinite(value),
        prefix + "is not finite (NaN, infinity and overflowing values are not allowed)", where);
  return value;
}

Error CsvTable::AtLine(const Error& error) const {
  const auto& record = error.context().record;
  if (!record || *record < 0 || static_cast<size_t>(*record) >= lines_.size()) {
    return Error(error.message(), {.file = path_});
  }
  return Error(error.message(), LineContext(path_, lines_[static_cast<size_t>(*record)]));
}

std::string CsvCell(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string out = "\"";
  for (char ch : text) out += ch == '"' ? std::string("\"\"") : std::string(1, ch);
  return out + "\"";
}

std::string CsvNumber(double value) {
  if (!std::isfinite(value)) return "";
  char buffer[32];
  return std::string(buffer, std::to_chars(buffer, buffer + sizeof(buffer), value).ptr);
}

}  // namespace wm::metrics

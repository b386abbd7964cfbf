#include "evaluate/report/report_dir.h"

#include <charconv>
#include <cmath>
#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"
#include "metrics/value/csv_table.h"

namespace wm::report {
namespace fs = std::filesystem;
using metrics::CsvTable;

namespace {

ErrorContext At(const CsvTable& t, size_t row) {
  return {.file = t.path(), .record = t.line(row), .record_label = "line"};
}

// An empty cell is an undefined number (NaN); anything else must be a finite number.
double OptionalNumber(const CsvTable& t, size_t row, size_t column) {
  return t.Cell(row, column).empty() ? kUndefined : t.Number(row, column);
}

int64_t Integer(const CsvTable& t, size_t row, size_t column, const char* what) {
  const std::string& cell = t.NonEmpty(row, column);
  int64_t value = -1;
  auto [end, error] = std::from_chars(cell.data(), cell.data() + cell.size(), value);
  Check(error == std::errc() && end == cell.data() + cell.size() && value >= 0,
        "column '" + t.header()[column] + "': '" + cell + "' is not " + what, At(t, row));
  return value;
}

// Every row's `checkpoint` cell names the report's checkpoint.
void CheckCheckpointColumn(const CsvTable& t, const std::string& name) {
  const size_t column = t.Column("checkpoint");
  for (size_t r = 0; r < t.rows(); ++r) {
    Check(t.Cell(r, column) == name,
          "column 'checkpoint': '" + t.Cell(r, column) + "', but manifest.json names the " +
              "checkpoint '" + name + "'",
          At(t, r));
  }
}

CsvTable ReadTable(const std::string& path) {
  Check(fs::is_regular_file(path), "missing file (not a wm-eval report directory?)",
        {.file = path});
  CsvTable table = CsvTable::Read(path);
  Check(table.rows() > 0, "no rows after the header", {.file = path});
  return table;
}

nlohmann::json ReadManifest(const std::string& path) {
  Check(fs::is_regular_file(path), "missing file (not a wm-eval report directory?)",
        {.file = path});
  nlohmann::json m;
  try {
    m = nlohmann::json::parse(ReadFile(path));
  } catch (const nlohmann::json::parse_error& e) {
    throw Error(std::string("not valid JSON: ") + e.what(), {.file = path});
  }
  Check(m.is_object(), "expected a JSON object", {.file = path});
  auto require = [&](const nlohmann::json& object, const std::string& key,
                     const std::string& label) {
    Check(object.contains(key), "missing key", {.file = path, .key = label});
  };
  require(m, "checkpoint", "checkpoint");
  Check(m["checkpoint"].is_object(), "expected an object", {.file = path, .key = "checkpoint"});
  for (const char* key : {"name", "sha256"}) {
    require(m["checkpoint"], key, std::string("checkpoint.") + key);
    Check(m["checkpoint"][key].is_string() && !m["checkpoint"][key].get<std::string>().empty(),
          "expected a non-empty string", {.file = path, .key = std::string("checkpoint.") + key});
  }
  for (const char* key : {"config_hash", "seed", "git_commit"}) require(m, key, key);
  if (m.contains("scale")) {
    Check(m["scale"].is_number() && m["scale"].get<double>() > 0, "expected a number > 0",
          {.file = path, .key = "scale"});
  }
  return m;
}

void ReadSummary(const std::string& path, CheckpointReport& report) {
  const CsvTable t = ReadTable(path);
  CheckCheckpointColumn(t, report.name);
  const size_t rollout = t.Column("rollout"), metric = t.Column("metric"), mean = t.Column("mean"),
               low = t.Column("ci_low"), high = t.Column("ci_high"), n = t.Column("n");
  for (size_t r = 0; r < t.rows(); ++r) {
    const SummaryEntry e{.mean = OptionalNumber(t, r, mean),
                         .ci_low = OptionalNumber(t, r, low),
                         .ci_high = OptionalNumber(t, r, high),
                         .n = Integer(t, r, n, "a count")};
    const auto key = std::make_pair(t.NonEmpty(r, rollout), t.NonEmpty(r, metric));
    Check(report.summary.emplace(key, e).second,
          "rollout '" + key.first + "', metric '" + key.second + "' is listed twice", At(t, r));
  }
}

void ReadPerEpisode(const std::string& path, CheckpointReport& report) {
  const CsvTable t = ReadTable(path);
  CheckCheckpointColumn(t, report.name);
  const size_t rollout = t.Column("rollout"), episode = t.Column("episode"),
               policy = t.Column("policy_id"), metric = t.Column("metric"),
               value = t.Column("value");
  for (size_t r = 0; r < t.rows(); ++r) {
    const auto key = std::make_pair(t.NonEmpty(r, rollout), t.NonEmpty(r, metric));
    const int64_t k = Integer(t, r, episode, "an episode index");
    const EpisodeValue v{t.NonEmpty(r, policy), OptionalNumber(t, r, value), t.line(r)};
    Check(report.per_episode[key].emplace(k, v).second,
          "rollout '" + key.first + "', metric '" + key.second + "', episode " + std::to_string(k) +
              " is listed twice",
          At(t, r));
  }
}

}  // namespace

bool CheckpointReport::HasRollout(const std::string& rollout) const {
  auto it = summary.lower_bound({rollout, ""});
  return it != summary.end() && it->first.first == rollout;
}

std::string CheckpointReport::SummaryPath() const {
  return (fs::path(dir) / "summary.csv").string();
}

std::string CheckpointReport::PerEpisodePath() const {
  return (fs::path(dir) / "per_episode.csv").string();
}

CheckpointReport ReadCheckpointReport(const std::string& dir) {
  Check(fs::is_directory(dir), "not a directory (expected REPORT_DIR/<checkpoint>)", {.file = dir});
  CheckpointReport report;
  report.dir = dir;
  report.manifest = ReadManifest((fs::path(dir) / "manifest.json").string());
  report.name = report.manifest["checkpoint"]["name"].get<std::string>();
  ReadSummary(report.SummaryPath(), report);
  ReadPerEpisode(report.PerEpisodePath(), report);
  return report;
}

}  // namespace wm::report

#pragma once
// One checkpoint's report directory as wm-eval writes it (docs/reports.md), read and checked for
// `wm-report compare`: manifest.json, summary.csv and per_episode.csv. Every error names the file
// and, for a bad row, its line and column, e.g.
//   reports/ckpt-a/summary.csv: line 4: column 'n': '-1' is not a count
#include <cstdint>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

namespace wm::report {

// An undefined number: an empty CSV cell.
inline constexpr double kUndefined = std::numeric_limits<double>::quiet_NaN();

// A summary.csv row: the mean over episodes (or over policies for value metrics) and its
// bootstrap interval; NaN where the file's cell is empty (undefined).
struct SummaryEntry {
  double mean = 0, ci_low = 0, ci_high = 0;
  int64_t n = 0;  // episodes (policies for value metrics) behind the mean
};

// A per_episode.csv value; NaN where the cell is empty (e.g. PSNR of identical frames).
struct EpisodeValue {
  std::string policy_id;
  double value = 0;
  int64_t line = 0;  // 1-based line in per_episode.csv, for errors
};

// NOLINTNEXTLINE(bugprone-exception-escape): nlohmann::json's destructor, not ours.
struct CheckpointReport {
  std::string dir;   // the report directory as given
  std::string name;  // manifest checkpoint.name; every CSV row's `checkpoint` equals it
  nlohmann::json manifest;
  // Keyed by (rollout, metric).
  std::map<std::pair<std::string, std::string>, SummaryEntry> summary;
  // Keyed by (rollout, metric), then by episode index (ascending).
  std::map<std::pair<std::string, std::string>, std::map<int64_t, EpisodeValue>> per_episode;

  bool HasRollout(const std::string& rollout) const;
  std::string SummaryPath() const;
  std::string PerEpisodePath() const;
};

// Reads manifest.json, summary.csv and per_episode.csv of `dir`. Throws wm::Error for a missing
// or unreadable file, a manifest without checkpoint.name / checkpoint.sha256 / config_hash /
// seed / git_commit, a missing column, a malformed number or count, a `checkpoint` cell that is
// not the manifest's name, and a repeated (rollout, metric) or (rollout, metric, episode).
CheckpointReport ReadCheckpointReport(const std::string& dir);

}  // namespace wm::report

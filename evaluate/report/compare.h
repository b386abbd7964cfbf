#pragma once
// `wm-report compare`: checkpoints side by side, per rollout: each headline metric's mean and
// interval (from summary.csv), its difference to a baseline checkpoint with a paired bootstrap
// interval over the episodes both reports scored (from per_episode.csv), a rank, and its
// difference to the report's own copy_last baseline rollout, paired the same way.
// Semantics: docs/reports.md, "wm-report compare".
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "evaluate/report/report_dir.h"

namespace wm::report {

struct CompareOptions {
  std::string baseline;              // checkpoint name; empty: the first report given
  std::vector<std::string> metrics;  // empty: HeadlineMetrics() that some report has
  std::string rollout = "all";       // one rollout name (plain, retrace, ...) or "all"
  int resamples = 1000;              // paired bootstrap replicates; 0: no delta intervals
  uint64_t seed = 0;                 // seeds every paired bootstrap (each starts afresh)
  double level = 0.95;               // central coverage of the delta intervals
  void Check() const;                // throws wm::Error naming the bad option
};

// Paired difference candidate - baseline over episodes scored by both: its mean and percentile
// bootstrap interval (episodes resampled with replacement, the same draws for both sides).
struct PairedDelta {
  double delta = 0, ci_low = 0, ci_high = 0;  // interval NaN below 2 pairs or 0 resamples
  int64_t pairs = 0;
};
PairedDelta PairedBootstrapDelta(const std::vector<double>& candidate,
                                 const std::vector<double>& baseline, int resamples, uint64_t seed,
                                 double level);

// One metric of one row; everything NaN / nullopt is printed as an empty cell. mean, ci_low,
// ci_high come from summary.csv (NaN when the report lacks the metric or it is undefined); the
// delta is against the baseline checkpoint, same rollout.
struct MetricComparison {
  double mean = kUndefined, ci_low = kUndefined, ci_high = kUndefined;               // summary.csv
  double delta = kUndefined, delta_ci_low = kUndefined, delta_ci_high = kUndefined;  // vs baseline
  std::optional<bool> significant;  // the delta interval excludes 0; nullopt: untested
  std::optional<int64_t> rank;      // 1 = best among the checkpoints of this rollout
  int64_t pairs = 0;                // episodes behind the paired delta; 0: none
  // Against the same report's copy_last rollout ("does it beat copying?"): this row minus
  // copy_last, paired over episodes, with its interval; the verdict follows the metric's
  // direction: +1 better than copying, -1 worse (the interval excludes 0), 0 indistinguishable,
  // nullopt without an interval. Undefined in the copy_last rows themselves.
  double vs_copy_last = kUndefined, vs_copy_last_ci_low = kUndefined;
  double vs_copy_last_ci_high = kUndefined;
  std::optional<int> beats_copy_last;
};

struct ComparisonRow {
  std::string checkpoint, rollout;
  bool baseline = false;
  std::vector<MetricComparison> metrics;  // in Comparison::metrics order
};

struct Comparison {
  std::string baseline;
  std::vector<std::string> metrics;
  bool has_copy_last = false;  // some report has a copy_last rollout: the vs_copy_last columns
  // Grouped by rollout (plain, retrace, copy_last, tokenizer_recon, then others in byte order),
  // checkpoints in the order given; a checkpoint without a rollout has no row for it.
  std::vector<ComparisonRow> rows;
};

// Throws wm::Error for repeated checkpoint names, an unknown baseline, rollout or metric, a
// metric no summary.csv has, and episodes whose policy_id differs between two reports.
Comparison CompareReports(const std::vector<CheckpointReport>& reports, const CompareOptions& o);

}  // namespace wm::report

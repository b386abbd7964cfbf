#pragma once
// Means with bootstrap confidence intervals over episodes, and the rows of the report CSVs
// (docs/reports.md). Numbers are printed with %.9g so reruns give identical bytes.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace wm::evaluate {

struct MeanCi {
  double mean = 0, ci_low = 0, ci_high = 0;  // NaN when undefined (printed as an empty cell)
  int64_t n = 0;
};

// Mean of `values` (NaNs dropped) and its percentile bootstrap interval over resampled values
// (seeded mt19937_64, metrics/value/bootstrap.h). `resamples` 0 -> no interval.
MeanCi BootstrapMean(const std::vector<double>& values, int resamples, uint64_t seed,
                     double level = 0.95);

// Mean of the finite values (NaN when there are none): an episode's value of a per-step metric.
double FiniteMean(const std::vector<double>& values);

// "%.9g", or "" for NaN/inf.
std::string Cell(double value);

// Per-episode values of one checkpoint: values[rollout][metric][k] for episode k of
// `episodes`, and per-step values per_step[rollout][metric][t-1][...] over episodes.
struct ScoreTable {
  std::vector<int64_t> episodes;
  std::vector<std::string> policy_ids;  // per episode
  std::map<std::string, std::map<std::string, std::vector<double>>> per_episode;
  std::map<std::string, std::map<std::string, std::vector<std::vector<double>>>> per_step;
  // Metrics with a single value per rollout (fvd_style, correlations, ...): value and n.
  std::map<std::string, std::map<std::string, MeanCi>> whole_set;
};

// Writes summary.csv, per_step.csv and per_episode.csv into `dir` (atomically).
void WriteScoreCsvs(const std::string& dir, const std::string& checkpoint, const ScoreTable& t,
                    int resamples, uint64_t seed);

}  // namespace wm::evaluate

#include "evaluate/report/compare.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <set>

#include "core/error.h"
#include "core/log.h"
#include "evaluate/report/metric_direction.h"
#include "metrics/value/bootstrap.h"

namespace wm::report {
namespace {

std::string JoinNames(const std::vector<std::string>& names) {
  std::string text;
  for (const auto& n : names) text += (text.empty() ? "" : ", ") + n;
  return text;
}

// wm-eval's modes first, then its baselines, then anything else in byte order.
std::vector<std::string> OrderRollouts(const std::set<std::string>& present) {
  std::vector<std::string> order;
  for (const char* known :
       {"plain", "retrace", "copy_last", "copy_last_tokens", "tokenizer_recon"}) {
    if (present.contains(known)) order.push_back(known);
  }
  for (const auto& r : present) {
    if (std::find(order.begin(), order.end(), r) == order.end()) order.push_back(r);
  }
  return order;
}

std::vector<std::string> SelectRollouts(const std::vector<CheckpointReport>& reports,
                                        const std::string& wanted) {
  std::set<std::string> present;
  for (const auto& r : reports) {
    for (const auto& [key, entry] : r.summary) present.insert(key.first);
  }
  std::vector<std::string> all = OrderRollouts(present);
  if (wanted == "all") return all;
  Check(
      present.contains(wanted),
      "rollout '" + wanted + "' is in no compared summary.csv (they have: " + JoinNames(all) + ")",
      {.file = reports.front().SummaryPath(), .key = "--rollout"});
  return {wanted};
}

bool AnyReportHas(const std::vector<CheckpointReport>& reports,
                  const std::vector<std::string>& rollouts, const std::string& metric) {
  for (const auto& r : reports) {
    for (const auto& rollout : rollouts) {
      if (r.summary.contains({rollout, metric})) return true;
    }
  }
  return false;
}

std::vector<std::string> SelectMetrics(const std::vector<CheckpointReport>& reports,
                                       const std::vector<std::string>& rollouts,
                                       const std::vector<std::string>& wanted) {
  std::vector<std::string> metrics;
  if (wanted.empty()) {
    for (const auto& m : HeadlineMetrics()) {
      if (AnyReportHas(reports, rollouts, m)) metrics.push_back(m);
    }
    Check(!metrics.empty(), "no headline metric (" + JoinNames(HeadlineMetrics()) + ") found",
          {.file = reports.front().SummaryPath()});
    return metrics;
  }
  for (const auto& m : wanted) {
    Check(MetricDirection(m).has_value(),
          "unknown metric '" + m + "' (known: " + KnownMetricsText() + ")", {.key = "--metrics"});
    Check(AnyReportHas(reports, rollouts, m),
          "metric '" + m + "' is in no compared summary.csv for rollout " + JoinNames(rollouts),
          {.file = reports.front().SummaryPath(), .key = "--metrics"});
    if (std::find(metrics.begin(), metrics.end(), m) == metrics.end()) metrics.push_back(m);
  }
  return metrics;
}

size_t BaselineIndex(const std::vector<CheckpointReport>& reports, const std::string& baseline) {
  std::vector<std::string> names;
  for (size_t i = 0; i < reports.size(); ++i) {
    for (size_t j = 0; j < i; ++j) {
      Check(reports[j].name != reports[i].name,
            "checkpoint name '" + reports[i].name + "' is also the name of " + reports[j].dir +
                ": names must differ to be compared",
            {.file = reports[i].dir + "/manifest.json", .key = "checkpoint.name"});
    }
    names.push_back(reports[i].name);
  }
  if (baseline.empty()) return 0;
  auto it = std::find(names.begin(), names.end(), baseline);
  Check(it != names.end(),
        "'" + baseline + "' is none of the compared checkpoints (" + JoinNames(names) + ")",
        {.key = "--baseline"});
  return static_cast<size_t>(it - names.begin());
}

// The (candidate, baseline) values of the episodes both reports scored with a defined value.
std::pair<std::vector<double>, std::vector<double>> PairEpisodes(
    const CheckpointReport& candidate, const std::map<int64_t, EpisodeValue>& values,
    const std::map<int64_t, EpisodeValue>& base_values, const CheckpointReport& base) {
  std::pair<std::vector<double>, std::vector<double>> pairs;
  for (const auto& [episode, v] : values) {
    auto it = base_values.find(episode);
    if (it == base_values.end()) continue;
    Check(v.policy_id == it->second.policy_id,
          "column 'policy_id': episode " + std::to_string(episode) + " is '" + v.policy_id +
              "' here but '" + it->second.policy_id + "' in " + base.PerEpisodePath() + " (line " +
              std::to_string(it->second.line) + "): the reports were made on different data",
          {.file = candidate.PerEpisodePath(), .record = v.line, .record_label = "line"});
    if (std::isfinite(v.value) && std::isfinite(it->second.value)) {
      pairs.first.push_back(v.value);
      pairs.second.push_back(it->second.value);
    }
  }
  return pairs;
}

size_t DefinedCount(const std::map<int64_t, EpisodeValue>& values) {
  return static_cast<size_t>(std::count_if(
      values.begin(), values.end(), [](const auto& v) { return std::isfinite(v.second.value); }));
}

using Key = std::pair<std::string, std::string>;  // (rollout, metric)

// The paired delta of `key` in `candidate` minus `base_key` in `base` over the episodes both
// scored with a defined value; nullopt when either lacks per-episode values or none pair.
std::optional<PairedDelta> PairedAgainst(const CheckpointReport& candidate, const Key& key,
                                         const CheckpointReport& base, const Key& base_key,
                                         const CompareOptions& o) {
  auto values = candidate.per_episode.find(key);
  auto base_values = base.per_episode.find(base_key);
  if (values == candidate.per_episode.end() || base_values == base.per_episode.end()) {
    return std::nullopt;
  }
  auto [a, b] = PairEpisodes(candidate, values->second, base_values->second, base);
  if (a.empty()) return std::nullopt;
  const size_t own_n = DefinedCount(values->second), base_n = DefinedCount(base_values->second);
  if (a.size() < std::max(own_n, base_n)) {
    spdlog::warn("{} {} vs {} {} ({}): paired on the {} episodes both scored ({} and {})",
                 candidate.name, key.first, base.name, base_key.first, key.second, a.size(), own_n,
                 base_n);
  }
  return PairedBootstrapDelta(a, b, o.resamples, o.seed, o.level);
}

// Only whole-set values (fvd_style, correlations, value_gap, ...): their difference, no interval.
double SummaryDifference(const CheckpointReport& candidate, const Key& key,
                         const CheckpointReport& base, const Key& base_key) {
  auto own = candidate.summary.find(key);
  auto other = base.summary.find(base_key);
  if (own == candidate.summary.end() || other == base.summary.end()) return kUndefined;
  return own->second.mean - other->second.mean;
}

std::optional<bool> ExcludesZero(const PairedDelta& d) {
  if (!std::isfinite(d.ci_low) || !std::isfinite(d.ci_high)) return std::nullopt;
  return d.ci_low > 0 || d.ci_high < 0;
}

// The row against its own report's copy_last rollout, the verdict in the metric's direction.
void CompareWithCopyLast(const CheckpointReport& report, const Key& key, MetricComparison& c,
                         const CompareOptions& o) {
  const Key copy_last = {"copy_last", key.second};
  if (key.first == copy_last.first || !report.HasRollout(copy_last.first)) return;
  const auto d = PairedAgainst(report, key, report, copy_last, o);
  if (!d) {
    c.vs_copy_last = SummaryDifference(report, key, report, copy_last);
    return;
  }
  c.vs_copy_last = d->delta, c.vs_copy_last_ci_low = d->ci_low, c.vs_copy_last_ci_high = d->ci_high;
  if (auto excludes = ExcludesZero(*d)) {
    const bool higher = MetricDirection(key.second) == Direction::kHigherIsBetter;
    c.beats_copy_last = !*excludes ? 0 : (d->ci_low > 0) == higher ? 1 : -1;
  }
}

MetricComparison CompareOne(const CheckpointReport& candidate, const CheckpointReport& base,
                            bool is_baseline, const std::string& rollout, const std::string& metric,
                            const CompareOptions& o) {
  MetricComparison c;
  const Key key = {rollout, metric};
  auto own = candidate.summary.find(key);
  if (own != candidate.summary.end()) {
    c.mean = own->second.mean, c.ci_low = own->second.ci_low, c.ci_high = own->second.ci_high;
  }
  CompareWithCopyLast(candidate, key, c, o);
  if (is_baseline) return c;
  if (const auto d = PairedAgainst(candidate, key, base, key, o)) {
    c.delta = d->delta, c.delta_ci_low = d->ci_low, c.delta_ci_high = d->ci_high;
    c.pairs = d->pairs;
    c.significant = ExcludesZero(*d);
    return c;
  }
  c.delta = SummaryDifference(candidate, key, base, key);
  return c;
}

// Competition ranks ("1224") among the rows of each rollout with a defined mean.
void RankRows(Comparison& result) {
  for (size_t m = 0; m < result.metrics.size(); ++m) {
    const bool higher = MetricDirection(result.metrics[m]) == Direction::kHigherIsBetter;
    for (auto& row : result.rows) {
      MetricComparison& c = row.metrics[m];
      if (!std::isfinite(c.mean)) continue;
      int64_t better = 0;
      for (const auto& other : result.rows) {
        const double v = other.rollout == row.rollout ? other.metrics[m].mean : kUndefined;
        if (std::isfinite(v) && (higher ? v > c.mean : v < c.mean)) ++better;
      }
      c.rank = better + 1;
    }
  }
}

void WarnOnDifferentData(const CheckpointReport& a, const CheckpointReport& base) {
  const auto& ma = a.manifest;
  const auto& mb = base.manifest;
  if (ma.contains("data") && mb.contains("data") && ma["data"] != mb["data"]) {
    spdlog::warn("{} and the baseline {} were evaluated on different data (manifest.json 'data')",
                 a.name, base.name);
  }
}

}  // namespace

void CompareOptions::Check() const {
  wm::Check(resamples >= 0, "must be >= 0, got " + std::to_string(resamples),
            {.key = "--resamples"});
  wm::Check(level > 0 && level < 1, "must be in (0, 1), got " + std::to_string(level),
            {.key = "confidence level"});
  wm::Check(!rollout.empty(), "must name a rollout or be 'all'", {.key = "--rollout"});
}

PairedDelta PairedBootstrapDelta(const std::vector<double>& candidate,
                                 const std::vector<double>& baseline, int resamples, uint64_t seed,
                                 double level) {
  Check(candidate.size() == baseline.size(), "paired samples differ in length");
  const size_t n = candidate.size();
  std::vector<double> diff(n);
  for (size_t i = 0; i < n; ++i) diff[i] = candidate[i] - baseline[i];
  auto mean = [&](const std::vector<size_t>* draw) {
    double s = 0;
    for (size_t i = 0; i < n; ++i) s += diff[draw ? (*draw)[i] : i];
    return s / static_cast<double>(n);
  };
  PairedDelta d{.delta = n ? mean(nullptr) : kUndefined,
                .ci_low = kUndefined,
                .ci_high = kUndefined,
                .pairs = static_cast<int64_t>(n)};
  if (n < 2 || resamples <= 0) return d;
  std::mt19937_64 rng(seed);
  std::vector<double> replicates;
  replicates.reserve(static_cast<size_t>(resamples));
  for (int r = 0; r < resamples; ++r) {
    const auto draw = metrics::DrawStratified({n}, rng);
    replicates.push_back(mean(&draw[0]));
  }
  const metrics::Interval ci = metrics::PercentileInterval(std::move(replicates), level);
  d.ci_low = ci.low, d.ci_high = ci.high;
  return d;
}

Comparison CompareReports(const std::vector<CheckpointReport>& reports, const CompareOptions& o) {
  o.Check();
  Check(!reports.empty(), "no report directories to compare");
  const size_t base = BaselineIndex(reports, o.baseline);
  const std::vector<std::string> rollouts = SelectRollouts(reports, o.rollout);
  Comparison result{.baseline = reports[base].name,
                    .metrics = SelectMetrics(reports, rollouts, o.metrics),
                    .rows = {}};
  for (size_t i = 0; i < reports.size(); ++i) {
    if (i != base) WarnOnDifferentData(reports[i], reports[base]);
    result.has_copy_last |= reports[i].HasRollout("copy_last");
  }
  for (const auto& rollout : rollouts) {
    for (size_t i = 0; i < reports.size(); ++i) {
      if (!reports[i].HasRollout(rollout)) continue;
      ComparisonRow row{reports[i].name, rollout, i == base, {}};
      for (const auto& metric : result.metrics) {
        row.metrics.push_back(CompareOne(reports[i], reports[base], i == base, rollout, metric, o));
      }
      result.rows.push_back(std::move(row));
    }
  }
  RankRows(result);
  return result;
}

}  // namespace wm::report

#include "evaluate/aggregate.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>

#include "core/atomic_file.h"
#include "metrics/value/bootstrap.h"

namespace wm::evaluate {
namespace fs = std::filesystem;

double FiniteMean(const std::vector<double>& values) {
  double s = 0;
  int64_t n = 0;
  for (double x : values) {
    if (std::isfinite(x)) s += x, ++n;
  }
  return n ? s / static_cast<double>(n) : NAN;
}

MeanCi BootstrapMean(const std::vector<double>& values, int resamples, uint64_t seed,
                     double level) {
  std::vector<double> v;
  for (double x : values) {
    if (std::isfinite(x)) v.push_back(x);
  }
  MeanCi out{.mean = NAN, .ci_low = NAN, .ci_high = NAN, .n = static_cast<int64_t>(v.size())};
  if (v.empty()) return out;
  auto mean = [](const std::vector<double>& x) {
    double s = 0;
    for (double e : x) s += e;
    return s / static_cast<double>(x.size());
  };
  out.mean = mean(v);
  if (resamples <= 0) return out;
  std::mt19937_64 rng(seed);
  std::vector<double> replicates;
  for (int r = 0; r < resamples; ++r) {
    // Keep the draw alive: a range-for over DrawStratified(...)[0] would iterate a destroyed
    // temporary.
    const std::vector<std::vector<size_t>> draw = metrics::DrawStratified({v.size()}, rng);
    double s = 0;
    for (size_t i : draw[0]) s += v[i];
    replicates.push_back(s / static_cast<double>(v.size()));
  }
  metrics::Interval ci = metrics::PercentileInterval(replicates, level);
  out.ci_low = ci.low;
  out.ci_high = ci.high;
  return out;
}

std::string Cell(double value) {
  if (!std::isfinite(value)) return "";
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.9g", value);
  return buf;
}

namespace {

std::string Row(const std::vector<std::string>& cells) {
  std::string line;
  for (size_t i = 0; i < cells.size(); ++i) line += (i ? "," : "") + cells[i];
  return line + "\n";
}

std::vector<std::string> Stats(const MeanCi& m) {
  return {Cell(m.mean), Cell(m.ci_low), Cell(m.ci_high), std::to_string(m.n)};
}

std::vector<std::string> Join(std::vector<std::string> a, const std::vector<std::string>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

}  // namespace

void WriteScoreCsvs(const std::string& dir, const std::string& checkpoint, const ScoreTable& t,
                    int resamples, uint64_t seed) {
  std::string summary = "checkpoint,rollout,metric,mean,ci_low,ci_high,n\n";
  std::string per_step = "checkpoint,rollout,step,metric,mean,ci_low,ci_high,n\n";
  std::string per_episode = "checkpoint,rollout,episode,policy_id,metric,value\n";
  for (const auto& [rollout, metrics] : t.per_episode) {
    for (const auto& [metric, values] : metrics) {
      summary +=
          Row(Join({checkpoint, rollout, metric}, Stats(BootstrapMean(values, resamples, seed))));
      for (size_t k = 0; k < values.size(); ++k) {
        per_episode += Row({checkpoint, rollout, std::to_string(t.episodes[k]), t.policy_ids[k],
                            metric, Cell(values[k])});
      }
    }
    auto it = t.whole_set.find(rollout);
    if (it == t.whole_set.end()) continue;
    for (const auto& [metric, m] : it->second) {
      summary += Row(Join({checkpoint, rollout, metric}, Stats(m)));
    }
  }
  for (const auto& [rollout, metrics] : t.per_step) {
    for (const auto& [metric, steps] : metrics) {
      for (size_t s = 0; s < steps.size(); ++s) {
        per_step += Row(Join({checkpoint, rollout, std::to_string(s + 1), metric},
                             Stats(BootstrapMean(steps[s], resamples, seed))));
      }
    }
  }
  WriteFileAtomically((fs::path(dir) / "summary.csv").string(), summary);
  WriteFileAtomically((fs::path(dir) / "per_step.csv").string(), per_step);
  WriteFileAtomically((fs::path(dir) / "per_episode.csv").string(), per_episode);
}

}  // namespace wm::evaluate

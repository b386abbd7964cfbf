#include "metrics/value/bootstrap.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"

namespace wm::metrics {

void BootstrapOptions::Check() const {
  wm::Check(resamples >= 0, "must be >= 0 (0: no intervals), got " + std::to_string(resamples),
            {.key = "bootstrap resamples"});
  wm::Check(level > 0 && level < 1, "must be in (0, 1), got " + std::to_string(level),
            {.key = "confidence level"});
}

std::vector<std::vector<size_t>> DrawStratified(const std::vector<size_t>& sizes,
                                                std::mt19937_64& rng) {
  std::vector<std::vector<size_t>> draws(sizes.size());
  for (size_t g = 0; g < sizes.size(); ++g) {
    draws[g].resize(sizes[g]);
    for (size_t& index : draws[g]) index = static_cast<size_t>(rng() % sizes[g]);
  }
  return draws;
}

double Quantile(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return std::numeric_limits<double>::quiet_NaN();
  const double h = static_cast<double>(sorted.size() - 1) * q;
  const size_t below = static_cast<size_t>(std::floor(h));
  const size_t above = std::min(below + 1, sorted.size() - 1);
  return sorted[below] + (h - static_cast<double>(below)) * (sorted[above] - sorted[below]);
}

Interval PercentileInterval(std::vector<double> replicates, double level) {
  std::erase_if(replicates, [](double v) { return std::isnan(v); });
  std::sort(replicates.begin(), replicates.end());
  return {Quantile(replicates, (1 - level) / 2), Quantile(replicates, (1 + level) / 2),
          static_cast<int64_t>(replicates.size())};
}

}  // namespace wm::metrics

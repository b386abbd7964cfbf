#pragma once
// A policy's value as a success rate with its Wilson score interval, for the simulator's true
// values (wm-sim-policy) and a world model's estimates alike.
#include <algorithm>
#include <cmath>
#include <cstdint>

namespace wm::policy {

struct SuccessRate {
  double rate = 0;           // successes / trials (0 when there are none)
  double low = 0, high = 0;  // Wilson score interval at the requested level
};

// Wilson score interval (Wilson 1927; Brown, Cai & DasGupta 2001 recommend it over the normal
// approximation for small n or rates near 0 and 1). `z` = 1.959964 gives 95% coverage.
inline SuccessRate WilsonInterval(int64_t successes, int64_t trials, double z = 1.959963984540054) {
  if (trials <= 0) return {0, 0, 1};
  const double n = static_cast<double>(trials);
  const double p = static_cast<double>(successes) / n;
  const double z2 = z * z;
  const double centre = (p + z2 / (2 * n)) / (1 + z2 / n);
  const double half = z / (1 + z2 / n) * std::sqrt(p * (1 - p) / n + z2 / (4 * n * n));
  return {p, std::max(0.0, centre - half), std::min(1.0, centre + half)};
}

}  // namespace wm::policy

#pragma once
// Deterministic random numbers for the tabletop generator. std::*_distribution output is
// implementation-defined (libstdc++ and libc++ differ), so uniform and normal variates are
// derived here from std::mt19937_64's raw 64-bit output, whose sequence the standard fixes.
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>

#include "core/mix_bits.h"

namespace wm::tabletop {

class Rng {
 public:
  explicit Rng(uint64_t seed) : engine_(seed) {}
  uint64_t Bits() { return engine_(); }
  // Uniform in [0, 1) from the top 53 bits (exactly representable doubles).
  double Uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  // Uniform integer in [0, n); the modulo bias (< n / 2^64) is irrelevant here.
  uint64_t Index(uint64_t n) { return engine_() % n; }
  // Standard normal by Box-Muller; 1 - Uniform() lies in (0, 1] so the log is finite.
  double Normal() {
    const double u1 = 1.0 - Uniform();
    const double u2 = Uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
  }
  double Normal(double mean, double stddev) { return mean + stddev * Normal(); }

 private:
  std::mt19937_64 engine_;
};

}  // namespace wm::tabletop

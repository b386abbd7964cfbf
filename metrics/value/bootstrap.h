#pragma once
// Percentile bootstrap building blocks: seeded stratified resampling and percentile intervals.
// Randomness is one std::mt19937_64 used through its raw outputs (`x % n`, whose bias is below
// n / 2^64), as tokenize/frame_sampler.h does, because std::uniform_int_distribution differs
// between standard libraries; the same seed gives the same intervals everywhere.
#include <cstddef>
#include <cstdint>
#include <random>
#include <vector>

namespace wm::metrics {

struct BootstrapOptions {
  int resamples = 1000;  // bootstrap replicates; 0 computes no intervals
  uint64_t seed = 0;     // seeds the std::mt19937_64
  double level = 0.95;   // central coverage of the interval, in (0, 1)
  void Check() const;    // throws wm::Error naming the bad field
};

// One stratified resample: for stratum g of size sizes[g], sizes[g] indices drawn uniformly
// with replacement from [0, sizes[g]) (rng() % sizes[g]), strata in order, draws in order.
std::vector<std::vector<size_t>> DrawStratified(const std::vector<size_t>& sizes,
                                                std::mt19937_64& rng);

// The q-quantile (0 <= q <= 1) of sorted values by linear interpolation between closest ranks,
// numpy.percentile's default: h = (n - 1) q, v[floor h] + (h - floor h) (v[floor h + 1] -
// v[floor h]). NaN for no values.
double Quantile(const std::vector<double>& sorted, double q);

struct Interval {
  double low, high;  // NaN when no replicate is defined
  int64_t defined;   // replicates that were not NaN, which alone make the interval
};

// The percentile interval [Quantile((1 - level) / 2), Quantile((1 + level) / 2)] of the
// replicates that are not NaN.
Interval PercentileInterval(std::vector<double> replicates, double level);

}  // namespace wm::metrics

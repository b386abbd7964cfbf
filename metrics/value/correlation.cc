#include "metrics/value/correlation.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>

#include "core/error.h"

namespace wm::metrics {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void CheckPaired(const std::vector<double>& x, const std::vector<double>& y) {
  Check(x.size() == y.size(), "correlation of samples of different lengths (" +
                                  std::to_string(x.size()) + " and " + std::to_string(y.size()) +
                                  ")");
}

bool IsConstant(const std::vector<double>& v) {
  return std::all_of(v.begin(), v.end(), [&](double x) { return x == v[0]; });
}

double Mean(const std::vector<double>& v) {
  return std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

// Pairs within runs of equal values in a sorted sequence: sum of c (c - 1) / 2 over runs.
template <typename Equal>
int64_t TiedPairs(size_t n, Equal equal) {
  int64_t ties = 0, run = 1;
  for (size_t i = 1; i <= n; ++i) {
    if (i < n && equal(i - 1, i)) {
      ++run;
    } else {
      ties += run * (run - 1) / 2;
      run = 1;
    }
  }
  return ties;
}

// Sorts v ascending (bottom-up merge sort) and returns the number of pairs i < j with
// v[i] > v[j] in the input: the discordant pairs when v is y in (x, y) order.
int64_t SortCountingInversions(std::vector<double>& v) {
  const size_t n = v.size();
  std::vector<double> merged(n);
  int64_t inversions = 0;
  for (size_t width = 1; width < n; width *= 2) {
    for (size_t lo = 0; lo < n; lo += 2 * width) {
      const size_t mid = std::min(lo + width, n), hi = std::min(lo + 2 * width, n);
      size_t i = lo, j = mid, k = lo;
      while (i < mid && j < hi) {
        if (v[j] < v[i]) {
          inversions += static_cast<int64_t>(mid - i);  // v[j] is below all of v[i..mid)
          merged[k++] = v[j++];
        } else {
          merged[k++] = v[i++];
        }
      }
      std::copy(v.begin() + i, v.begin() + mid, merged.begin() + k);
      std::copy(v.begin() + j, v.begin() + hi, merged.begin() + k + (mid - i));
    }
    v.swap(merged);
  }
  return inversions;
}

}  // namespace

std::vector<double> AverageRanks(const std::vector<double>& values) {
  std::vector<size_t> order(values.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return values[a] < values[b]; });
  std::vector<double> ranks(values.size());
  for (size_t begin = 0; begin < order.size();) {
    size_t end = begin + 1;
    while (end < order.size() && values[order[end]] == values[order[begin]]) ++end;
    const double rank = 0.5 * static_cast<double>(begin + 1 + end);  // mean of begin+1 .. end
    for (size_t k = begin; k < end; ++k) ranks[order[k]] = rank;
    begin = end;
  }
  return ranks;
}

double Pearson(const std::vector<double>& x, const std::vector<double>& y) {
  CheckPaired(x, y);
  // Constancy is tested on the values: a mean of equal values can differ from them by rounding,
  // which would turn 0/0 into noise.
  if (x.size() < 2 || IsConstant(x) || IsConstant(y)) return kNaN;
  if (x.size() == 2) {
    return static_cast<double>(((x[1] > x[0]) - (x[1] < x[0])) * ((y[1] > y[0]) - (y[1] < y[0])));
  }
  const double mx = Mean(x), my = Mean(y);
  double sxy = 0, sxx = 0, syy = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    const double dx = x[i] - mx, dy = y[i] - my;
    sxy += dx * dy;
    sxx += dx * dx;
    syy += dy * dy;
  }
  return std::clamp(sxy / (std::sqrt(sxx) * std::sqrt(syy)), -1.0, 1.0);
}

double Spearman(const std::vector<double>& x, const std::vector<double>& y) {
  CheckPaired(x, y);
  return Pearson(AverageRanks(x), AverageRanks(y));
}

double KendallTauB(const std::vector<double>& x, const std::vector<double>& y) {
  CheckPaired(x, y);
  const size_t n = x.size();
  if (n < 2) return kNaN;
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](size_t a, size_t b) { return x[a] < x[b] || (x[a] == x[b] && y[a] < y[b]); });
  const auto same_x = [&](size_t i, size_t j) { return x[order[i]] == x[order[j]]; };
  const int64_t x_ties = TiedPairs(n, same_x);
  const int64_t joint_ties =
      TiedPairs(n, [&](size_t i, size_t j) { return same_x(i, j) && y[order[i]] == y[order[j]]; });
  std::vector<double> ys(n);
  for (size_t i = 0; i < n; ++i) ys[i] = y[order[i]];
  const int64_t discordant = SortCountingInversions(ys);
  const int64_t y_ties = TiedPairs(n, [&](size_t i, size_t j) { return ys[i] == ys[j]; });
  const int64_t total = static_cast<int64_t>(n) * static_cast<int64_t>(n - 1) / 2;
  if (x_ties == total || y_ties == total) return kNaN;
  // total = C + D + (x_ties - joint) + (y_ties - joint) + joint, so C - D is:
  const int64_t c_minus_d = total - x_ties - y_ties + joint_ties - 2 * discordant;
  const double tau = static_cast<double>(c_minus_d) / std::sqrt(double(total - x_ties)) /
                     std::sqrt(double(total - y_ties));
  return std::clamp(tau, -1.0, 1.0);
}

double Auroc(const std::vector<double>& score, const std::vector<bool>& positive) {
  Check(score.size() == positive.size(), "AUROC of " + std::to_string(score.size()) +
                                             " scores and " + std::to_string(positive.size()) +
                                             " labels");
  const std::vector<double> ranks = AverageRanks(score);
  double rank_sum = 0, n_pos = 0;
  for (size_t i = 0; i < score.size(); ++i) {
    if (positive[i]) rank_sum += ranks[i], n_pos += 1;
  }
  const double n_neg = static_cast<double>(score.size()) - n_pos;
  if (n_pos == 0 || n_neg == 0) return kNaN;
  return (rank_sum - n_pos * (n_pos + 1) / 2) / (n_pos * n_neg);
}

}  // namespace wm::metrics

// Ranks and correlation coefficients against values worked out by hand, and Kendall's tau-b
// (merge-sort algorithm) against the O(n^2) pair count it replaces. test_value_reference.py
// compares the same code with SciPy.
#include "metrics/value/correlation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace wm::metrics {
namespace {

// tau-b straight from its definition: every pair classified once.
double KendallByPairs(const std::vector<double>& x, const std::vector<double>& y) {
  double concordant = 0, discordant = 0, x_ties = 0, y_ties = 0, pairs = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    for (size_t j = i + 1; j < x.size(); ++j) {
      const double s = (x[i] - x[j]) * (y[i] - y[j]);
      ++pairs;
      x_ties += x[i] == x[j];
      y_ties += y[i] == y[j];
      concordant += s > 0;
      discordant += s < 0;
    }
  }
  return (concordant - discordant) / std::sqrt((pairs - x_ties) * (pairs - y_ties));
}

TEST(Correlation, AverageRanksShareTiedPositions) {
  EXPECT_EQ(AverageRanks({10, 20, 20, 30}), (std::vector<double>{1, 2.5, 2.5, 4}));
  EXPECT_EQ(AverageRanks({3, 1, 3, 3, 0}), (std::vector<double>{4, 2, 4, 4, 1}));
  EXPECT_TRUE(AverageRanks({}).empty());
}

TEST(Correlation, PearsonByHand) {
  // x = 1..5, y = 2 4 5 4 5: sxy = 6, sxx = 10, syy = 6 -> r = 6 / sqrt(60).
  EXPECT_NEAR(Pearson({1, 2, 3, 4, 5}, {2, 4, 5, 4, 5}), 6 / std::sqrt(60.0), 1e-15);
  EXPECT_DOUBLE_EQ(Pearson({1, 2, 3}, {-2, -4, -6}), -1.0);
  EXPECT_EQ(Pearson({0, 1}, {5, 3}), -1.0);  // two points: the sign, exactly
}

TEST(Correlation, SpearmanUsesAverageRanks) {
  // Ranks x: 1 2 3 4, y: 1 2.5 2.5 4 -> Pearson of those.
  const double expected = Pearson({1, 2, 3, 4}, {1, 2.5, 2.5, 4});
  EXPECT_DOUBLE_EQ(Spearman({0.1, 0.2, 0.3, 0.4}, {5, 7, 7, 9}), expected);
  EXPECT_NEAR(Spearman({1, 2, 3}, {1, 8, 27}), 1.0, 1e-15);  // monotone, not linear
}

TEST(Correlation, KendallTauBByHand) {
  // No ties: C = 5, D = 1 of 6 pairs.
  EXPECT_NEAR(KendallTauB({1, 2, 3, 4}, {1, 3, 2, 4}), 4.0 / 6, 1e-15);
  // x = 1 1 2 3, y = 1 2 2 3: C = 4, D = 0, one pair tied in x, one in y: 4 / sqrt(5 * 5).
  EXPECT_NEAR(KendallTauB({1, 1, 2, 3}, {1, 2, 2, 3}), 0.8, 1e-15);
  // A pair tied in both counts in both tie totals: x = y = 1 1 2 -> 2 / sqrt(2 * 2).
  EXPECT_NEAR(KendallTauB({1, 1, 2}, {1, 1, 2}), 1.0, 1e-15);
  EXPECT_NEAR(KendallTauB({1, 2, 3}, {3, 2, 1}), -1.0, 1e-15);
}

TEST(Correlation, KendallMergeSortMatchesPairCount) {
  std::mt19937_64 rng(3);
  for (int trial = 0; trial < 50; ++trial) {
    const size_t n = 2 + rng() % 60;
    const int levels = 2 + static_cast<int>(rng() % 8);  // few levels: many ties
    std::vector<double> x(n), y(n);
    for (size_t i = 0; i < n; ++i) {
      x[i] = static_cast<double>(rng() % levels);
      y[i] = static_cast<double>(rng() % levels) + 0.5 * x[i];
    }
    const double expected = KendallByPairs(x, y);
    if (std::isnan(expected)) continue;
    EXPECT_NEAR(KendallTauB(x, y), expected, 1e-12) << "trial " << trial;
  }
}

TEST(Correlation, UndefinedCasesAreNaN) {
  for (auto* f : {&Pearson, &Spearman, &KendallTauB}) {
    EXPECT_TRUE(std::isnan(f({1, 1, 1}, {1, 2, 3})));  // constant x
    EXPECT_TRUE(std::isnan(f({1, 2, 3}, {4, 4, 4})));  // constant y
    EXPECT_TRUE(std::isnan(f({1}, {2})));              // one pair
    EXPECT_TRUE(std::isnan(f({}, {})));
  }
  // The mean of equal values can differ from them by rounding; still undefined, not noise.
  EXPECT_TRUE(std::isnan(Pearson({0.1, 0.1, 0.1}, {1, 2, 3})));
}

// AUROC by hand: every (positive, negative) pair, 1 when the positive scores higher, 1/2 on ties.

TEST(Auroc, CountsOrderedPairsAndTiesHalf) {
  // Pairs (0.35, 0.1) 1, (0.35, 0.4) 0, (0.8, 0.1) 1, (0.8, 0.4) 1: 3 / 4.
  EXPECT_DOUBLE_EQ(Auroc({0.1, 0.4, 0.35, 0.8}, {false, false, true, true}), 0.75);
  // Pairs (2, 1) 1, (2, 2) 1/2, (3, 1) 1, (3, 2) 1: 3.5 / 4.
  EXPECT_DOUBLE_EQ(Auroc({1, 2, 2, 3}, {false, true, false, true}), 0.875);
  EXPECT_DOUBLE_EQ(Auroc({5, 1, 3}, {true, false, false}), 1.0);
  EXPECT_DOUBLE_EQ(Auroc({5, 1, 3}, {false, true, true}), 0.0);
  EXPECT_DOUBLE_EQ(Auroc({2, 2, 2}, {false, true, false}), 0.5);
  EXPECT_TRUE(std::isnan(Auroc({1, 2}, {true, true})));
  EXPECT_TRUE(std::isnan(Auroc({}, {})));
}

}  // namespace
}  // namespace wm::metrics

#pragma once
// Correlation coefficients between paired samples x[i], y[i], defined as SciPy 1.10 defines them
// (scipy.stats.pearsonr, spearmanr, kendalltau with its default variant 'b'), to which
// tests/metrics/value/test_value_reference.py compares them.
//
// Undefined cases return NaN and never throw: fewer than 2 pairs, or one side constant (zero
// variance: no linear or rank association can be measured). x and y must have equal lengths.
#include <vector>

namespace wm::metrics {

// 1-based ranks; tied values share the mean of the ranks they span (scipy.stats.rankdata's
// 'average' method): {10, 20, 20, 30} -> {1, 2.5, 2.5, 4}.
std::vector<double> AverageRanks(const std::vector<double>& values);

// Pearson's r = sum(dx dy) / sqrt(sum(dx^2) sum(dy^2)), d = deviation from the mean, clipped to
// [-1, 1]. Two pairs give sign(x1 - x0) * sign(y1 - y0) exactly, as SciPy.
double Pearson(const std::vector<double>& x, const std::vector<double>& y);

// Spearman's rho: Pearson's r of the average ranks.
double Spearman(const std::vector<double>& x, const std::vector<double>& y);

// Kendall's tau-b = (C - D) / sqrt((N0 - Tx) (N0 - Ty)): C / D concordant / discordant pairs,
// N0 = n(n-1)/2, Tx / Ty pairs tied in x / in y (a pair tied in both counts in both). Knight's
// O(n log n) algorithm (sort by x then y, count inversions of y by merge sort), as SciPy.
double KendallTauB(const std::vector<double>& x, const std::vector<double>& y);

// Area under the ROC curve of `score` for telling the `positive` items from the others: the
// probability that a random positive scores above a random negative, ties counting half. By
// ranks (the Mann-Whitney U of the positives over n_pos * n_neg): (sum of the positives' average
// ranks - n_pos (n_pos + 1) / 2) / (n_pos n_neg). NaN without positives or negatives.
double Auroc(const std::vector<double>& score, const std::vector<bool>& positive);

}  // namespace wm::metrics

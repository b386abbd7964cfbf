#pragma once
// The Fréchet distance between Gaussian fits of two feature sets, the statistic behind FID
// (Heusel et al. 2017) and FVD (Unterthiner et al. 2018): definition in docs/metrics.md.
#include <cstdint>
#include <vector>

namespace wm::metrics {

// Feature vectors as rows: `rows` samples of `dim` values each, row-major.
struct FeatureSet {
  int64_t rows = 0;
  int64_t dim = 0;
  std::vector<double> values;  // rows * dim
};

// The mean and covariance of a feature set. The covariance uses ddof = 1 (divides by rows - 1),
// numpy.cov's default and what the FID/FVD reference implementations use.
struct GaussianFit {
  int64_t dim = 0;
  int64_t samples = 0;
  std::vector<double> mean;        // dim
  std::vector<double> covariance;  // dim x dim, row-major, symmetric
};

// Throws wm::Error when there are fewer than 2 rows or values.size() != rows * dim.
GaussianFit FitGaussian(const FeatureSet& features);

// ||mu1 - mu2||^2 + Tr(S1 + S2 - 2 (S1 S2)^{1/2}), >= 0. Tr((S1 S2)^{1/2}) is computed as
// Tr((S1^{1/2} S2 S1^{1/2})^{1/2}) with symmetric eigendecompositions whose eigenvalues below
// the numerical-rank tolerance (largest * dim * epsilon, as numpy.linalg.matrix_rank) count as
// 0, so singular covariances (fewer samples than dimensions) are fine.
// Throws wm::Error when the dimensions differ.
double FrechetDistance(const GaussianFit& a, const GaussianFit& b);
double FrechetDistance(const FeatureSet& a, const FeatureSet& b);

}  // namespace wm::metrics

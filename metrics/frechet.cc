#include "metrics/frechet.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/error.h"

namespace wm::metrics {
namespace {

using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

void CheckFit(const GaussianFit& g, const char* which) {
  const auto d = static_cast<size_t>(g.dim);
  Check(g.dim > 0 && g.mean.size() == d && g.covariance.size() == d * d,
        std::string("Gaussian fit ") + which + " is malformed: dim " + std::to_string(g.dim) +
            ", " + std::to_string(g.mean.size()) + " mean values, " +
            std::to_string(g.covariance.size()) + " covariance values");
}

// Eigenvalues of a symmetric positive semi-definite matrix with those below its numerical rank
// tolerance (numpy.linalg.matrix_rank's: largest * dim * epsilon) set to 0. Rounding leaves
// zero eigenvalues of singular covariances at about +-1e-16 * largest; their square roots would
// add about 1e-8 * sqrt(largest) each to the trace.
Eigen::VectorXd PsdEigenvalues(const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>& solver) {
  const Eigen::VectorXd& values = solver.eigenvalues();
  const double tolerance = values.cwiseAbs().maxCoeff() * static_cast<double>(values.size()) *
                           std::numeric_limits<double>::epsilon();
  return values.unaryExpr([tolerance](double v) { return v > tolerance ? v : 0.0; });
}

}  // namespace

GaussianFit FitGaussian(const FeatureSet& f) {
  Check(f.rows >= 2, "a Gaussian fit needs at least 2 feature rows, got " + std::to_string(f.rows));
  Check(f.dim > 0 && f.values.size() == static_cast<size_t>(f.rows * f.dim),
        "feature set of " + std::to_string(f.rows) + "x" + std::to_string(f.dim) + " holds " +
            std::to_string(f.values.size()) + " values");
  Eigen::Map<const RowMajorMatrix> x(f.values.data(), f.rows, f.dim);  // [N, D]
  const Eigen::RowVectorXd mu = x.colwise().mean();                    // [1, D]
  const Eigen::MatrixXd centered = x.rowwise() - mu;                   // [N, D]
  Eigen::MatrixXd cov(f.dim, f.dim);                                   // [D, D]
  cov.setZero();
  cov.selfadjointView<Eigen::Lower>().rankUpdate(centered.transpose(), 1.0 / (f.rows - 1.0));
  cov = cov.selfadjointView<Eigen::Lower>();

  GaussianFit g;
  g.dim = f.dim;
  g.samples = f.rows;
  g.mean.assign(mu.data(), mu.data() + f.dim);
  g.covariance.resize(static_cast<size_t>(f.dim * f.dim));
  Eigen::Map<RowMajorMatrix>(g.covariance.data(), f.dim, f.dim) = cov;
  return g;
}

double FrechetDistance(const GaussianFit& a, const GaussianFit& b) {
  CheckFit(a, "1");
  CheckFit(b, "2");
  Check(a.dim == b.dim,
        "feature dimensions differ: " + std::to_string(a.dim) + " vs " + std::to_string(b.dim));
  const int64_t d = a.dim;
  Eigen::Map<const Eigen::VectorXd> mu1(a.mean.data(), d), mu2(b.mean.data(), d);
  Eigen::Map<const RowMajorMatrix> s1(a.covariance.data(), d, d), s2(b.covariance.data(), d, d);

  // S1^{1/2} from S1 = V L V^T; then S1^{1/2} S2 S1^{1/2} is symmetric PSD and has the same
  // eigenvalues as S1 S2, so the trace of its square root is Tr((S1 S2)^{1/2}).
  const Eigen::MatrixXd s1_dense = s1;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig1(s1_dense);
  const Eigen::MatrixXd v = eig1.eigenvectors();
  const Eigen::MatrixXd sqrt_s1 =
      v * PsdEigenvalues(eig1).cwiseSqrt().asDiagonal() * v.transpose();  // [D, D]
  Eigen::MatrixXd m = sqrt_s1 * s2 * sqrt_s1;
  m = 0.5 * (m + m.transpose()).eval();  // remove rounding asymmetry before the solver
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig_m(m, Eigen::EigenvaluesOnly);
  const double trace_sqrt = PsdEigenvalues(eig_m).cwiseSqrt().sum();

  const double distance = (mu1 - mu2).squaredNorm() + s1.trace() + s2.trace() - 2.0 * trace_sqrt;
  // A distance is >= 0; for identical fits rounding can leave about -1e-12.
  return std::max(distance, 0.0);
}

double FrechetDistance(const FeatureSet& a, const FeatureSet& b) {
  Check(a.dim == b.dim,
        "feature dimensions differ: " + std::to_string(a.dim) + " vs " + std::to_string(b.dim));
  return FrechetDistance(FitGaussian(a), FitGaussian(b));
}

}  // namespace wm::metrics

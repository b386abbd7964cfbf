#pragma once
// Scaling-law fits of a loss (or any metric) y against a resource x: compute, parameters or data
// (WHALE-X §4.3: training loss against model size, data and FLOPs). Two forms:
//
//   power      y = a x^(-b) + c       (Ceres, autodiff; c is the irreducible loss)
//   loglinear  log y = log a - b log x (the straight line on log-log axes; c = 0)
//
// Standard errors come from the linearised covariance sigma^2 (J^T J)^-1 at the solution, with
// sigma^2 = RSS / (n - p) (ceres::Covariance, then scaled). Ceres stays in scaling_fit.cc.
// Definitions, bounds, robust losses and degenerate cases: docs/metrics-value.md.
#include <optional>
#include <string>
#include <vector>

namespace wm::metrics {

struct ScalingPoint {
  double x;           // resource, > 0
  double y;           // loss or metric at x; > 0 for the loglinear form
  std::string label;  // optional name (e.g. "39M"), carried to the output
};

enum class ScalingForm { kPower, kLogLinear };
enum class RobustLoss { kNone, kHuber, kCauchy };

struct ScalingFitOptions {
  ScalingForm form = ScalingForm::kPower;
  // A robust loss bounds the pull of outlying points: Huber (quadratic within `robust_scale`,
  // linear beyond) or Cauchy (log(1 + (r/s)^2)). Residuals are y units (log y for loglinear).
  RobustLoss robust = RobustLoss::kNone;
  // Scale s of the robust loss; 0 = automatic: k * 1.4826 * MAD of the least-squares residuals
  // with k = 1.345 (Huber) or 2.385 (Cauchy), the 95%-efficiency constants.
  double robust_scale = 0;
  // Lower bounds of the power form's b and c (Ceres box constraints); nullopt = unbounded.
  // The loglinear form has no bounds.
  std::optional<double> b_min = 0.0;
  std::optional<double> c_min = 0.0;
  int max_iterations = 500;  // Levenberg-Marquardt iterations
  void Check() const;        // throws wm::Error naming the bad option
};

struct FitParameter {
  double value;
  double std_error;  // NaN when not estimable (n == p or a rank-deficient Jacobian)
};

struct ScalingFit {
  ScalingForm form;
  RobustLoss robust;
  double robust_scale;   // as used (NaN without a robust loss)
  FitParameter a, b, c;  // c is {0, NaN} for the loglinear form
  int points = 0;        // n
  int dof = 0;           // n - p, p = 3 (power) or 2 (loglinear)
  double rss = 0;        // sum of squared residuals, in the fitted space (log y for loglinear)
  double sigma2 = 0;     // rss / dof; NaN when dof == 0
  double r2 = 0;         // 1 - rss / total sum of squares, in the same space
  bool converged = false;
  int iterations = 0;
  std::string termination;  // Ceres' termination type, e.g. "CONVERGENCE"
  // b or c ended on its lower bound: the fit is constrained there, so that parameter's standard
  // error (from the unconstrained curvature) is no confidence statement.
  bool at_bound = false;
  double covariance[3][3] = {};  // of (a, b, c), for Predict's standard error; NaN if unknown
};

// Fits `points` (n >= p, x > 0, all finite; y > 0 for loglinear). Throws wm::Error on bad
// points or options.
ScalingFit FitScalingLaw(const std::vector<ScalingPoint>& points, const ScalingFitOptions& options);

struct Prediction {
  double x, y;
  double std_error;  // delta method: sqrt(g^T Cov g), g = dy/d(a, b, c); NaN when Cov is unknown
};

// The fitted curve at x > 0 (extrapolation when x lies outside the fitted range).
Prediction Predict(const ScalingFit& fit, double x);

std::string ToString(ScalingForm form);  // "power", "loglinear"
std::string ToString(RobustLoss loss);   // "none", "huber", "cauchy"

}  // namespace wm::metrics

#include "metrics/scaling/scaling_fit.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <set>

#include "core/error.h"

namespace wm::metrics {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The solver works in u = log(x / x0), x0 the geometric mean of the x values, so that the
// amplitude and the exponent are nearly uncorrelated and x = 1e21 FLOPs stays well scaled. Its
// parameters theta are (A, b, c) with A the amplitude at x0: power y = A exp(-b u) + c,
// loglinear log y = A - b u (c unused). MapToUser turns them into (a, b, c) of y = a x^-b + c.

struct PowerResidual {
  double u, y;
  template <typename T>
  bool operator()(const T* theta, T* residual) const {
    residual[0] = T(y) - (theta[0] * exp(-theta[1] * T(u)) + theta[2]);
    return true;
  }
};

struct LogLinearResidual {
  double u, log_y;
  template <typename T>
  bool operator()(const T* theta, T* residual) const {
    residual[0] = T(log_y) - (theta[0] - theta[1] * T(u));
    return true;
  }
};

// The points in the solver's space.
struct Data {
  std::vector<double> u, y;  // y is log y for loglinear
  double log_x0 = 0;
  int p = 3;  // free parameters
};

double Mean(const std::vector<double>& v) {
  return std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

double Median(std::vector<double> v) {
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  if (v.size() % 2) return v[mid];
  return 0.5 * (v[mid] + *std::max_element(v.begin(), v.begin() + mid));
}

Data MakeData(const std::vector<ScalingPoint>& points, const ScalingFitOptions& o) {
  Data d;
  d.p = o.form == ScalingForm::kPower ? 3 : 2;
  std::set<double> distinct_x;
  for (size_t i = 0; i < points.size(); ++i) {
    const ScalingPoint& pt = points[i];
    const ErrorContext where{.record = static_cast<int64_t>(i), .record_label = "point"};
    Check(std::isfinite(pt.x) && pt.x > 0, "x must be finite and > 0", where);
    Check(std::isfinite(pt.y), "y must be finite", where);
    Check(o.form == ScalingForm::kPower || pt.y > 0, "the loglinear form needs y > 0", where);
    distinct_x.insert(pt.x);
    d.u.push_back(std::log(pt.x));
    d.y.push_back(o.form == ScalingForm::kPower ? pt.y : std::log(pt.y));
  }
  Check(static_cast<int>(distinct_x.size()) >= d.p,
        "the " + ToString(o.form) + " form has " + std::to_string(d.p) +
            " parameters and needs points at that many distinct x values, got " +
            std::to_string(distinct_x.size()));
  d.log_x0 = Mean(d.u);
  for (double& u : d.u) u -= d.log_x0;
  return d;
}

// Least squares of y against t (slope, intercept) in closed form; with `intercept_min` the
// intercept is held there when the free one falls below it. Returns the residual sum of squares.
double FitLine(const std::vector<double>& t, const std::vector<double>& y,
               const std::optional<double>& intercept_min, double& slope, double& intercept) {
  const double mt = Mean(t), my = Mean(y);
  double stt = 0, sty = 0;
  for (size_t i = 0; i < t.size(); ++i) stt += (t[i] - mt) * (t[i] - mt);
  for (size_t i = 0; i < t.size(); ++i) sty += (t[i] - mt) * (y[i] - my);
  slope = sty / stt, intercept = my - slope * mt;
  if (intercept_min && intercept < *intercept_min) {
    intercept = *intercept_min;
    double sy = 0, s2 = 0;
    for (size_t i = 0; i < t.size(); ++i) sy += t[i] * (y[i] - intercept), s2 += t[i] * t[i];
    slope = sy / s2;
  }
  double rss = 0;
  for (size_t i = 0; i < t.size(); ++i) rss += std::pow(y[i] - slope * t[i] - intercept, 2);
  return rss;
}

// Start values. Loglinear: the least-squares line (already the answer). Power: for a fixed b the
// model is linear in (A, c), so the start is the best b on a log-spaced grid of 400 values in
// [max(b_min, 1e-3), max(10, 10 b_min)] with its closed-form (A, c): Levenberg-Marquardt from a
// poor start can stall in the flat valley along which b and c trade off.
void StartValues(const Data& d, const ScalingFitOptions& o, double theta[3]) {
  if (o.form == ScalingForm::kLogLinear) {
    double slope = 0;
    FitLine(d.u, d.y, std::nullopt, slope, theta[0]);
    theta[1] = -slope, theta[2] = 0;
    return;
  }
  const double lo = std::max(o.b_min.value_or(0.0), 1e-3), hi = std::max(10.0, 10 * lo);
  theta[0] = 0, theta[1] = lo, theta[2] = std::max(o.c_min.value_or(0.0), 0.0);  // if all overflow
  double best = std::numeric_limits<double>::infinity();
  std::vector<double> t(d.u.size());
  for (int k = 0; k < 400; ++k) {
    const double b = lo * std::pow(hi / lo, k / 399.0);
    for (size_t i = 0; i < t.size(); ++i) t[i] = std::exp(-b * d.u[i]);
    double amplitude = 0, c = 0;
    const double rss = FitLine(t, d.y, o.c_min, amplitude, c);
    if (rss < best) best = rss, theta[0] = amplitude, theta[1] = b, theta[2] = c;
  }
}

ceres::LossFunction* MakeLoss(RobustLoss loss, double scale) {
  switch (loss) {
    case RobustLoss::kHuber:
      return new ceres::HuberLoss(scale);
    case RobustLoss::kCauchy:
      return new ceres::CauchyLoss(scale);
    case RobustLoss::kNone:
      break;
  }
  return nullptr;
}

ceres::CostFunction* MakeCost(ScalingForm form, double u, double y) {
  if (form == ScalingForm::kPower) {
    return new ceres::AutoDiffCostFunction<PowerResidual, 1, 3>(new PowerResidual{u, y});
  }
  return new ceres::AutoDiffCostFunction<LogLinearResidual, 1, 2>(new LogLinearResidual{u, y});
}

// One residual block per point on the parameter block theta, with the power form's bounds.
std::unique_ptr<ceres::Problem> BuildProblem(const Data& d, const ScalingFitOptions& o,
                                             ceres::LossFunction* loss, double* theta) {
  auto problem = std::make_unique<ceres::Problem>();
  for (size_t i = 0; i < d.u.size(); ++i) {
    // The problem owns the cost functions and deletes a loss shared by all blocks once.
    problem->AddResidualBlock(MakeCost(o.form, d.u[i], d.y[i]), loss, theta);
  }
  if (o.form == ScalingForm::kPower) {
    if (o.b_min) problem->SetParameterLowerBound(theta, 1, *o.b_min);
    if (o.c_min) problem->SetParameterLowerBound(theta, 2, *o.c_min);
  }
  return problem;
}

ceres::Solver::Summary Solve(ceres::Problem& problem, const ScalingFitOptions& o) {
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = o.max_iterations;
  // Tight tolerances: the standard errors are only as good as the optimum they linearise at.
  so.function_tolerance = 1e-15;
  so.gradient_tolerance = 1e-15;
  so.parameter_tolerance = 1e-14;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  Check(summary.IsSolutionUsable(), "the scaling-law fit failed: " + summary.message);
  return summary;
}

// Plain residuals at the current parameters, loss function not applied.
std::vector<double> Residuals(ceres::Problem& problem) {
  ceres::Problem::EvaluateOptions eo;
  eo.apply_loss_function = false;
  std::vector<double> residuals;
  problem.Evaluate(eo, nullptr, &residuals, nullptr, nullptr);
  return residuals;
}

// (J^T J)^-1 of the unweighted residuals at theta (p x p, row-major); false when J is
// rank-deficient.
bool UnscaledCovariance(ceres::Problem& problem, double* theta, double* cov) {
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;  // tiny and dense; fails cleanly on a singular J
  co.apply_loss_function = false;
  ceres::Covariance covariance(co);
  const std::vector<std::pair<const double*, const double*>> blocks = {{theta, theta}};
  if (!covariance.Compute(blocks, &problem)) return false;
  return covariance.GetCovarianceBlock(theta, theta, cov);
}

// From theta = (A, b, c) at x0 to (a, b, c) at x = 1 and the covariance by the Jacobian G of
// that map: power a = A e^(b log x0), loglinear a = e^(A + b log x0).
void MapToUser(const Data& d, ScalingForm form, const double theta[3], const double* cov_theta,
               double sigma2, ScalingFit& fit) {
  const double growth = std::exp(theta[1] * d.log_x0);
  const double a = form == ScalingForm::kPower ? theta[0] * growth : std::exp(theta[0]) * growth;
  const double da_dA = form == ScalingForm::kPower ? growth : a;
  const double g[3][3] = {{da_dA, a * d.log_x0, 0}, {0, 1, 0}, {0, 0, d.p == 3 ? 1.0 : 0.0}};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      double sum = 0;
      for (int k = 0; k < d.p; ++k) {
        for (int l = 0; l < d.p; ++l) sum += g[i][k] * cov_theta[k * d.p + l] * g[j][l];
      }
      fit.covariance[i][j] = sum * sigma2;
    }
  }
  auto se = [&](int i) { return std::sqrt(fit.covariance[i][i]); };
  fit.a = {a, se(0)};
  fit.b = {theta[1], se(1)};
  fit.c = d.p == 3 ? FitParameter{theta[2], se(2)} : FitParameter{0.0, kNaN};
}

// k * 1.4826 * MAD: MAD * 1.4826 estimates sigma for Gaussian residuals; k gives 95% efficiency.
double AutoScale(RobustLoss loss, const std::vector<double>& residuals) {
  const double m = Median(residuals);
  std::vector<double> deviations(residuals.size());
  for (size_t i = 0; i < residuals.size(); ++i) deviations[i] = std::abs(residuals[i] - m);
  return (loss == RobustLoss::kHuber ? 1.345 : 2.385) * 1.4826 * Median(deviations);
}

void Summarise(const Data& d, const ceres::Solver::Summary& s, const std::vector<double>& r,
               ScalingFit& fit) {
  fit.points = static_cast<int>(d.u.size());
  fit.dof = fit.points - d.p;
  fit.rss = std::inner_product(r.begin(), r.end(), r.begin(), 0.0);
  fit.sigma2 = fit.dof > 0 ? fit.rss / fit.dof : kNaN;
  const double my = Mean(d.y);
  double tss = 0;
  for (double y : d.y) tss += (y - my) * (y - my);
  fit.r2 = tss > 0 ? 1 - fit.rss / tss : kNaN;
  fit.converged = s.termination_type == ceres::CONVERGENCE;
  fit.iterations = s.num_successful_steps + s.num_unsuccessful_steps;
  fit.termination = ceres::TerminationTypeToString(s.termination_type);
}

}  // namespace

void ScalingFitOptions::Check() const {
  wm::Check(std::isfinite(robust_scale) && robust_scale >= 0,
            "must be >= 0 (0: automatic), got " + std::to_string(robust_scale),
            {.key = "robust scale"});
  wm::Check(max_iterations > 0, "must be > 0", {.key = "max iterations"});
  wm::Check(!b_min || std::isfinite(*b_min), "must be finite", {.key = "b_min"});
  wm::Check(!c_min || std::isfinite(*c_min), "must be finite", {.key = "c_min"});
}

ScalingFit FitScalingLaw(const std::vector<ScalingPoint>& points, const ScalingFitOptions& o) {
  o.Check();
  const Data d = MakeData(points, o);
  double theta[3];
  StartValues(d, o, theta);
  std::unique_ptr<ceres::Problem> problem = BuildProblem(d, o, nullptr, theta);
  ceres::Solver::Summary summary = Solve(*problem, o);
  ScalingFit fit{.form = o.form, .robust = o.robust, .robust_scale = kNaN};
  if (o.robust != RobustLoss::kNone) {
    // Robust refit from the least-squares optimum; an exact least-squares fit (scale 0) has no
    // outliers to discount and is kept.
    fit.robust_scale =
        o.robust_scale > 0 ? o.robust_scale : AutoScale(o.robust, Residuals(*problem));
    if (fit.robust_scale > 0) {
      problem = BuildProblem(d, o, MakeLoss(o.robust, fit.robust_scale), theta);
      summary = Solve(*problem, o);
    }
  }
  Summarise(d, summary, Residuals(*problem), fit);
  double cov_theta[9];
  if (fit.dof == 0 || !UnscaledCovariance(*problem, theta, cov_theta)) {
    std::fill(cov_theta, cov_theta + 9, kNaN);
  }
  MapToUser(d, o.form, theta, cov_theta, fit.sigma2, fit);
  // Ceres projects onto an active bound, so equality is exact there.
  fit.at_bound = o.form == ScalingForm::kPower &&
                 ((o.b_min && theta[1] <= *o.b_min) || (o.c_min && theta[2] <= *o.c_min));
  return fit;
}

Prediction Predict(const ScalingFit& fit, double x) {
  Check(std::isfinite(x) && x > 0, "extrapolation needs x > 0, got " + std::to_string(x));
  const double xb = std::pow(x, -fit.b.value);
  const double g[3] = {xb, -fit.a.value * xb * std::log(x),
                       fit.form == ScalingForm::kPower ? 1.0 : 0.0};
  double variance = 0;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      if (g[i] != 0 && g[j] != 0) variance += g[i] * fit.covariance[i][j] * g[j];
    }
  }
  return {x, fit.a.value * xb + fit.c.value, variance >= 0 ? std::sqrt(variance) : kNaN};
}

std::string ToString(ScalingForm form) {
  return form == ScalingForm::kPower ? "power" : "loglinear";
}

std::string ToString(RobustLoss loss) {
  switch (loss) {
    case RobustLoss::kHuber:
      return "huber";
    case RobustLoss::kCauchy:
      return "cauchy";
    case RobustLoss::kNone:
      break;
  }
  return "none";
}

}  // namespace wm::metrics

// Scaling-law fits on synthetic points with known parameters, standard errors against the
// closed-form least-squares formulas, bounds, robust losses and bad input.
// test_scaling_reference.py checks the same code through wm-metrics against SciPy.
#include "metrics/scaling/scaling_fit.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/error.h"
#include "tests/core/test_util.h"

namespace wm::metrics {
namespace {

using ::testing::HasSubstr;

// n points y = a x^-b + c (+ Gaussian noise of `sigma`) at x log-spaced over [x0, x1].
std::vector<ScalingPoint> PowerLaw(double a, double b, double c, double x0, double x1, int n,
                                   double sigma = 0, uint64_t seed = 0) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0, sigma > 0 ? sigma : 1);
  std::vector<ScalingPoint> points;
  for (int i = 0; i < n; ++i) {
    const double x = x0 * std::pow(x1 / x0, i / (n - 1.0));
    points.push_back({x, a * std::pow(x, -b) + c + (sigma > 0 ? noise(rng) : 0), ""});
  }
  return points;
}

void ExpectRelative(double got, double want, double tolerance, const char* what) {
  EXPECT_NEAR(got, want, tolerance * std::abs(want)) << what;
}

TEST(ScalingFit, RecoversANoiseFreePowerLaw) {
  for (auto [a, b, c, x0, x1] :
       {std::tuple{3.0, 0.3, 0.5, 1e6, 1e10}, std::tuple{40.0, 0.35, 1.7, 1e3, 1e9},
        std::tuple{2.5e3, 0.12, 1.9, 1e18, 1e23}}) {  // FLOPs
    const ScalingFit fit = FitScalingLaw(PowerLaw(a, b, c, x0, x1, 9), {});
    ExpectRelative(fit.a.value, a, 1e-6, "a");
    ExpectRelative(fit.b.value, b, 1e-6, "b");
    ExpectRelative(fit.c.value, c, 1e-6, "c");
    EXPECT_TRUE(fit.converged) << fit.termination;
    EXPECT_EQ(fit.points, 9);
    EXPECT_EQ(fit.dof, 6);
    EXPECT_NEAR(fit.r2, 1.0, 1e-12);
    EXPECT_FALSE(fit.at_bound);
    ExpectRelative(Predict(fit, x1 * 100).y, a * std::pow(x1 * 100, -b) + c, 1e-9, "extrap");
  }
}

TEST(ScalingFit, SmallNoiseRecoversParametersToOnePercent) {
  const ScalingFit fit = FitScalingLaw(PowerLaw(40, 0.35, 1.7, 1e3, 1e9, 13, 1e-3, 4), {});
  ExpectRelative(fit.a.value, 40, 0.01, "a");
  ExpectRelative(fit.b.value, 0.35, 0.01, "b");
  ExpectRelative(fit.c.value, 1.7, 0.01, "c");
  for (const FitParameter& p : {fit.a, fit.b, fit.c}) {
    EXPECT_GT(p.std_error, 0);
    EXPECT_LT(p.std_error, 0.01 * std::abs(p.value));
  }
  EXPECT_NEAR(fit.sigma2, 1e-6, 1e-6);  // the noise variance, within its sampling spread
}

TEST(ScalingFit, LogLinearStandardErrorsAreTheOlsFormulas) {
  std::vector<ScalingPoint> points = PowerLaw(5, 0.2, 0, 1e2, 1e8, 10);
  std::mt19937_64 rng(9);
  for (auto& p : points) p.y *= std::exp(0.01 * ((rng() % 1000) / 500.0 - 1));
  const ScalingFit fit = FitScalingLaw(points, {.form = ScalingForm::kLogLinear});
  // Ordinary least squares of log y on u = log x: slope -b, intercept log a.
  double mu = 0, my = 0;
  for (const auto& p : points) mu += std::log(p.x) / 10, my += std::log(p.y) / 10;
  double suu = 0, suy = 0;
  for (const auto& p : points) {
    suu += std::pow(std::log(p.x) - mu, 2);
    suy += (std::log(p.x) - mu) * (std::log(p.y) - my);
  }
  const double slope = suy / suu, intercept = my - slope * mu;
  double rss = 0;
  for (const auto& p : points)
    rss += std::pow(std::log(p.y) - intercept - slope * std::log(p.x), 2);
  const double sigma2 = rss / 8;
  ExpectRelative(fit.b.value, -slope, 1e-9, "b");
  ExpectRelative(fit.a.value, std::exp(intercept), 1e-9, "a");
  ExpectRelative(fit.rss, rss, 1e-6, "rss");
  ExpectRelative(fit.b.std_error, std::sqrt(sigma2 / suu), 1e-6, "se b");
  ExpectRelative(fit.a.std_error, fit.a.value * std::sqrt(sigma2 * (0.1 + mu * mu / suu)), 1e-6,
                 "se a");
  EXPECT_EQ(fit.c.value, 0);
  EXPECT_TRUE(std::isnan(fit.c.std_error));
}

TEST(ScalingFit, BoundsHoldAndAreReported) {
  const std::vector<ScalingPoint> points = PowerLaw(2, 0.5, -0.01, 1e2, 1e6, 8);  // c < 0
  const ScalingFit bounded = FitScalingLaw(points, {});
  EXPECT_EQ(bounded.c.value, 0.0);
  EXPECT_TRUE(bounded.at_bound);
  const ScalingFit free = FitScalingLaw(points, {.b_min = std::nullopt, .c_min = std::nullopt});
  ExpectRelative(free.c.value, -0.01, 1e-6, "c");
  EXPECT_FALSE(free.at_bound);
}

TEST(ScalingFit, RobustLossesResistAnOutlier) {
  std::vector<ScalingPoint> points = PowerLaw(40, 0.35, 1.7, 1e3, 1e9, 13, 1e-3, 5);
  points[6].y += 0.5;  // one diverged run
  const ScalingFit plain = FitScalingLaw(points, {});
  for (RobustLoss loss : {RobustLoss::kHuber, RobustLoss::kCauchy}) {
    const ScalingFit robust = FitScalingLaw(points, {.robust = loss});
    EXPECT_GT(robust.robust_scale, 0) << ToString(loss);
    EXPECT_LT(std::abs(robust.b.value - 0.35), std::abs(plain.b.value - 0.35)) << ToString(loss);
    EXPECT_LT(std::abs(robust.c.value - 1.7), std::abs(plain.c.value - 1.7)) << ToString(loss);
  }
  EXPECT_TRUE(std::isnan(plain.robust_scale));
}

TEST(ScalingFit, ExactlyDeterminedFitHasNoStandardErrors) {
  const ScalingFit fit = FitScalingLaw(PowerLaw(3, 0.3, 0.5, 1, 1e4, 3), {});
  ExpectRelative(fit.b.value, 0.3, 1e-6, "b");
  EXPECT_EQ(fit.dof, 0);
  EXPECT_TRUE(std::isnan(fit.sigma2));
  EXPECT_TRUE(std::isnan(fit.b.std_error));
  EXPECT_TRUE(std::isnan(Predict(fit, 1e5).std_error));
}

TEST(ScalingFit, BadInputIsAnError) {
  auto error = [](std::vector<ScalingPoint> points, ScalingFitOptions o = {}) {
    return test::ErrorText([&] { FitScalingLaw(points, o); });
  };
  EXPECT_THAT(error({{1, 1, ""}, {2, 0.5, ""}}), HasSubstr("needs points at that many distinct x"));
  EXPECT_THAT(error({{1, 1, ""}, {1, 0.5, ""}, {1, 0.7, ""}}), HasSubstr("got 1"));
  EXPECT_THAT(error({{1, 1, ""}, {-2, 0.5, ""}, {3, 0.2, ""}}),
              HasSubstr("point 1: x must be finite and > 0"));
  EXPECT_THAT(error({{1, 1, ""}, {2, -0.5, ""}}, {.form = ScalingForm::kLogLinear}),
              HasSubstr("point 1: the loglinear form needs y > 0"));
  EXPECT_THAT(error({{1, NAN, ""}}), HasSubstr("point 0: y must be finite"));
  EXPECT_THAT(error(PowerLaw(1, 1, 0, 1, 10, 4), {.robust_scale = -1}), HasSubstr("robust scale"));
  EXPECT_THAT(test::ErrorText([] { Predict(ScalingFit{}, 0); }), HasSubstr("x > 0"));
}

}  // namespace
}  // namespace wm::metrics

// Pixel metrics and the Fréchet distance against values worked out by hand or in closed form.
// test_metrics_reference.py checks the same code against scikit-image and SciPy.
#include "metrics/pixel_metrics.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <random>

#include "core/error.h"
#include "metrics/frechet.h"
#include "tests/core/test_util.h"

namespace wm::metrics {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

Image Constant(int h, int w, int c, uint8_t value) {
  std::vector<uint8_t> pixels(size_t(h) * w * c, value);
  return Image::FromUint8(pixels.data(), h, w, c);
}

Image Random(int h, int w, int c, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<uint8_t> pixels(size_t(h) * w * c);
  for (auto& p : pixels) p = static_cast<uint8_t>(rng() >> 56);
  return Image::FromUint8(pixels.data(), h, w, c);
}

// `image` plus Gaussian noise of standard deviation `sigma`, clipped to [0, 255].
Image Noisy(const Image& image, double sigma, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0, sigma);
  Image out = image;
  for (double& p : out.pixels) p = std::clamp(std::round(p + noise(rng)), 0.0, 255.0);
  return out;
}

// SSIM's luminance term for constant images: variances and covariance vanish, so cs = 1
// (Wang et al. 2004, eq. 13 with sigma = 0).
double ConstantLuminance(double x, double y) {
  const double c1 = std::pow(0.01 * 255, 2);
  return (2 * x * y + c1) / (x * x + y * y + c1);
}

std::string ErrorOf(const std::function<void()>& fn) { return test::ErrorText(fn); }

TEST(PixelMetrics, MseAndPsnrByHand) {
  const uint8_t a[] = {0, 10, 20, 30}, b[] = {1, 12, 20, 26};  // differences 1, 2, 0, 4
  const Image ia = Image::FromUint8(a, 2, 2, 1), ib = Image::FromUint8(b, 2, 2, 1);
  EXPECT_DOUBLE_EQ(Mse(ia, ib), 21.0 / 4);
  EXPECT_NEAR(Psnr(ia, ib), 40.92921057461954, 1e-12);  // 10 log10(255^2 / 5.25)

  const float fa[] = {0.5f, 0.25f, 1.0f}, fb[] = {0.25f, 0.25f, 1.0f};  // one RGB pixel
  const Image ja = Image::FromFloat(fa, 1, 1, 3), jb = Image::FromFloat(fb, 1, 1, 3);
  EXPECT_DOUBLE_EQ(Mse(ja, jb), 0.0625 / 3);
  EXPECT_NEAR(Psnr(ja, jb), 10 * std::log10(3 / 0.0625), 1e-12);
  EXPECT_NEAR(PsnrFromMse(0.0625, 1.0), 12.041199826559248, 1e-12);  // 10 log10(16)
}

TEST(PixelMetrics, IdenticalFramesGiveInfinitePsnrAndUnitSsim) {
  const Image a = Random(40, 50, 3, 1);
  EXPECT_EQ(Mse(a, a), 0);
  EXPECT_TRUE(std::isinf(Psnr(a, a)) && Psnr(a, a) > 0);
  EXPECT_NEAR(Ssim(a, a), 1.0, 1e-12);
  const Image big = Random(180, 190, 1, 2);
  EXPECT_NEAR(MsSsim(big, big), 1.0, 1e-12);
}

TEST(PixelMetrics, SsimOfConstantImagesIsTheLuminanceTerm) {
  EXPECT_NEAR(Ssim(Constant(20, 30, 1, 100), Constant(20, 30, 1, 110)), 0.9954764440915066, 1e-10);
  EXPECT_NEAR(Ssim(Constant(20, 30, 3, 100), Constant(20, 30, 3, 110)), ConstantLuminance(100, 110),
              1e-10);
}

TEST(PixelMetrics, SsimIsSymmetricAndBelowOne) {
  const Image a = Random(37, 53, 3, 3), b = Noisy(a, 20, 4);
  const double ab = Ssim(a, b), ba = Ssim(b, a);
  EXPECT_NEAR(ab, ba, 1e-14);
  EXPECT_LT(ab, 0.99);
  EXPECT_GT(ab, 0.5);
  EXPECT_LT(Ssim(a, Noisy(a, 40, 5)), ab);  // more noise, less similar
}

TEST(PixelMetrics, SsimMapCoversTheImageAndItsCroppedMeanIsTheSsim) {
  const Image a = Random(30, 41, 3, 6), b = Noisy(a, 15, 7);
  Image map;
  const double ssim = Ssim(a, b, &map);
  ASSERT_EQ(map.height, 30);
  ASSERT_EQ(map.width, 41);
  ASSERT_EQ(map.channels, 3);
  double sum = 0;
  for (int y = kSsimCrop; y < 30 - kSsimCrop; ++y) {
    for (int x = kSsimCrop; x < 41 - kSsimCrop; ++x) {
      for (int c = 0; c < 3; ++c) sum += map.at(y, x, c);
    }
  }
  EXPECT_NEAR(sum / (20.0 * 31 * 3), ssim, 1e-12);
  EXPECT_EQ(Ssim(a, b), ssim);  // the map does not change the mean
}

TEST(PixelMetrics, ResultsDoNotDependOnTheThreadCount) {
  const Image a = Random(200, 180, 3, 8), b = Noisy(a, 10, 9);
  EXPECT_EQ(Ssim(a, b, nullptr, 1), Ssim(a, b, nullptr, 4));
  EXPECT_EQ(MsSsim(a, b, 1), MsSsim(a, b, 3));
}

TEST(PixelMetrics, MsSsimOfConstantImagesIsTheWeightedLuminance) {
  // Every cs_j is 1 for constant images, so MS-SSIM = l^w5 with w5 = 0.1333.
  EXPECT_NEAR(MsSsim(Constant(176, 200, 3, 100), Constant(176, 200, 3, 110)), 0.9993958246284796,
              1e-10);
}

TEST(PixelMetrics, MsSsimFallsWithNoise) {
  const Image a = Random(192, 192, 1, 10);
  const double light = MsSsim(a, Noisy(a, 5, 11)), heavy = MsSsim(a, Noisy(a, 30, 12));
  EXPECT_LT(light, 1.0);
  EXPECT_LT(heavy, light);
  EXPECT_GE(heavy, 0.0);
}

TEST(PixelMetrics, ClearErrorsOnBadInputs) {
  EXPECT_THAT(ErrorOf([] { MsSsim(Random(175, 300, 3, 1), Random(175, 300, 3, 2)); }),
              AllOf(HasSubstr("176x176"), HasSubstr("175x300")));
  EXPECT_THAT(ErrorOf([] { Ssim(Random(10, 30, 1, 1), Random(10, 30, 1, 2)); }),
              AllOf(HasSubstr("11x11"), HasSubstr("10x30")));
  EXPECT_THAT(ErrorOf([] { Mse(Random(12, 12, 1, 1), Random(12, 13, 1, 2)); }),
              HasSubstr("12x12x1 vs 12x13x1"));
  const float f[] = {0.5f};
  const uint8_t u[] = {128};
  EXPECT_THAT(ErrorOf([&] { Mse(Image::FromFloat(f, 1, 1, 1), Image::FromUint8(u, 1, 1, 1)); }),
              HasSubstr("data range"));
  EXPECT_THAT(ErrorOf([&] { Image::FromUint8(u, 1, 1, 2); }), HasSubstr("1 or 3 channels"));
}

TEST(PixelMetrics, VideosArePerFrameThenMeaned) {
  std::vector<Image> a, b;
  for (int t = 0; t < 5; ++t) {
    a.push_back(Random(24, 20, 3, 20 + t));
    b.push_back(t == 2 ? a.back() : Noisy(a.back(), 10 + 5 * t, 30 + t));
  }
  MetricOptions options;
  options.ms_ssim = false;
  options.threads = 3;
  const VideoMetrics v = CompareVideos(a, b, options);
  ASSERT_EQ(v.frames.size(), 5u);
  double ssim_sum = 0;
  for (int t = 0; t < 5; ++t) {
    EXPECT_EQ(v.frames[t].ssim, Ssim(a[t], b[t]));
    EXPECT_EQ(v.frames[t].mse, Mse(a[t], b[t]));
    EXPECT_TRUE(std::isnan(v.frames[t].ms_ssim));
    ssim_sum += v.frames[t].ssim;
  }
  EXPECT_DOUBLE_EQ(v.mean.ssim, ssim_sum / 5);
  EXPECT_TRUE(std::isinf(v.mean.psnr));  // frame 2 is identical

  b.pop_back();
  EXPECT_THAT(ErrorOf([&] { CompareFrames(a, b, options); }), HasSubstr("5 vs 4"));
  b.push_back(Random(24, 21, 3, 1));
  EXPECT_THAT(ErrorOf([&] { CompareFrames(a, b, options); }), HasSubstr("frame 4"));
}

TEST(PixelMetrics, JsonSafeNumbers) {
  EXPECT_EQ(JsonNumber(INFINITY).dump(), "\"inf\"");
  EXPECT_EQ(JsonNumber(-INFINITY).dump(), "\"-inf\"");
  EXPECT_EQ(JsonNumber(NAN).dump(), "null");
  EXPECT_EQ(JsonNumber(0.5).dump(), "0.5");
  const nlohmann::json j = ToJson({0.0, INFINITY, 1.0, NAN});
  EXPECT_EQ(j.dump(), R"({"mse":0.0,"psnr":"inf","ssim":1.0})");
}

// --- Fréchet distance --------------------------------------------------------------------

GaussianFit Diagonal(const std::vector<double>& mean, const std::vector<double>& variances) {
  GaussianFit g;
  g.dim = static_cast<int64_t>(mean.size());
  g.samples = 100;
  g.mean = mean;
  g.covariance.assign(mean.size() * mean.size(), 0.0);
  for (size_t i = 0; i < mean.size(); ++i) g.covariance[i * mean.size() + i] = variances[i];
  return g;
}

FeatureSet RandomFeatures(int64_t rows, int64_t dim, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  FeatureSet f{rows, dim, std::vector<double>(size_t(rows * dim))};
  for (double& v : f.values) v = normal(rng);
  return f;
}

TEST(Frechet, DiagonalGaussiansHaveTheClosedForm) {
  // Diagonal covariances commute: d = sum (mu1 - mu2)^2 + sum (sigma1 - sigma2)^2.
  const GaussianFit a = Diagonal({0, 1, 2}, {1, 4, 9}), b = Diagonal({1, 1, 0}, {4, 4, 0.25});
  const double expected = (1 + 0 + 4) + (1 + 0 + 6.25);
  EXPECT_NEAR(FrechetDistance(a, b), expected, 1e-12);
}

TEST(Frechet, ScaledCovarianceHasTheClosedForm) {
  // S2 = k^2 S1 -> Tr(S1 + S2 - 2 (S1 S2)^{1/2}) = (1 - k)^2 Tr(S1), for a full S1.
  const GaussianFit a = FitGaussian(RandomFeatures(50, 6, 1));
  GaussianFit b = a;
  for (double& v : b.covariance) v *= 9.0;  // k = 3
  double trace = 0;
  for (int i = 0; i < 6; ++i) trace += a.covariance[i * 6 + i];
  EXPECT_NEAR(FrechetDistance(a, b), 4.0 * trace, 1e-10 * trace);
}

TEST(Frechet, FitUsesSampleCovariance) {
  // Orthogonal +-1 columns with zero mean: the ddof=1 covariance is diag(4 / 3 * s^2).
  const FeatureSet f{4, 2, {1, 2, 1, -2, -1, 2, -1, -2}};
  const GaussianFit g = FitGaussian(f);
  EXPECT_DOUBLE_EQ(g.mean[0], 0.0);
  EXPECT_DOUBLE_EQ(g.covariance[0], 4.0 / 3);
  EXPECT_DOUBLE_EQ(g.covariance[3], 16.0 / 3);
  EXPECT_DOUBLE_EQ(g.covariance[1], 0.0);
}

TEST(Frechet, IdenticalSetsAreAtZeroAndShiftsCostTheirSquaredNorm) {
  const FeatureSet x = RandomFeatures(200, 16, 2);
  EXPECT_NEAR(FrechetDistance(x, x), 0.0, 1e-9);
  FeatureSet shifted = x;
  for (size_t i = 0; i < shifted.values.size(); ++i) shifted.values[i] += (i % 16 == 3 ? 2 : 0);
  EXPECT_NEAR(FrechetDistance(x, shifted), 4.0, 1e-8);
}

TEST(Frechet, SingularCovariancesAreFiniteAndNonNegative) {
  // 5 samples in 32 dimensions: both covariances have rank 4.
  const FeatureSet x = RandomFeatures(5, 32, 3), y = RandomFeatures(5, 32, 4);
  const double d = FrechetDistance(x, y);
  EXPECT_TRUE(std::isfinite(d));
  EXPECT_GT(d, 0.0);
  FeatureSet shifted = x;
  for (double& v : shifted.values) v += 0.5;  // same singular covariance, mean moved by 0.5 * 1
  EXPECT_NEAR(FrechetDistance(x, shifted), 0.25 * 32, 1e-8);
}

TEST(Frechet, ClearErrorsOnBadInputs) {
  EXPECT_THAT(ErrorOf([] { FrechetDistance(RandomFeatures(5, 3, 1), RandomFeatures(5, 4, 2)); }),
              HasSubstr("3 vs 4"));
  EXPECT_THAT(ErrorOf([] { FitGaussian(RandomFeatures(1, 3, 1)); }), HasSubstr("at least 2"));
}

}  // namespace
}  // namespace wm::metrics

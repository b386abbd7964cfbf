// The scores a frozen or blurred prediction cannot win (evaluate/motion_scores.h) against numbers
// worked out by hand on 2x2 frames: moved_error_ratio, ΔtPSNR and the per-frame PSNR under it.
#include "evaluate/motion_scores.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>

namespace wm::evaluate {
namespace {

using Rgb = std::array<int, 3>;

// A clip of 2x2 frames given as 8-bit RGB per pixel, stored planar in [-1, 1] as wm-eval's clips
// are (PlanarToRgb8 gives the same bytes back).
Clip Frames(const std::vector<std::array<Rgb, 4>>& frames) {
  Clip c{.frames = static_cast<int64_t>(frames.size()), .size = 2, .pixels = {}};
  for (const auto& f : frames) {
    for (int ch = 0; ch < 3; ++ch) {
      for (const Rgb& px : f) c.pixels.push_back(static_cast<float>(px[ch]) / 127.5f - 1.f);
    }
  }
  return c;
}

const Rgb kGrey = {100, 100, 100};

TEST(MovedErrorRatio, IsErrorToTheTruthOverErrorToTheStartOnMovedPixelsOnly) {
  const Clip first = Frames({{kGrey, kGrey, kGrey, kGrey}});
  // Step 1: pixel 1 moved (G +40), pixel 3 moved (R +100, G -50); pixel 2 changed by exactly
  // 30 levels (not "more than 30": not moved), pixel 0 not at all.
  // Step 2: nothing moved. Step 3: pixel 3 moved, and the prediction is the first frame.
  const Clip real = Frames({{kGrey, Rgb{100, 140, 100}, Rgb{130, 100, 100}, Rgb{200, 50, 100}},
                            {kGrey, kGrey, kGrey, kGrey},
                            {kGrey, kGrey, kGrey, Rgb{0, 0, 0}}});
  // Pixels 0 and 2 are far off but did not move: they must not count.
  const Clip pred = Frames({{Rgb{0, 0, 0}, Rgb{100, 130, 100}, Rgb{255, 0, 0}, Rgb{150, 80, 100}},
                            {Rgb{0, 0, 0}, kGrey, kGrey, kGrey},
                            {kGrey, kGrey, kGrey, kGrey}});
  const std::vector<double> r = MovedErrorRatio(first, real, pred);
  ASSERT_EQ(r.size(), 3u);
  // |pred - real|: pixel 1: 0 + 10 + 0, pixel 3: 50 + 30 + 0 -> 90.
  // |pred - first|: pixel 1: 0 + 30 + 0, pixel 3: 50 + 20 + 0 -> 100.
  EXPECT_DOUBLE_EQ(r[0], 0.9);
  EXPECT_TRUE(std::isnan(r[1]));  // no pixel moved
  EXPECT_TRUE(std::isnan(r[2]));  // a copy of the first frame: 0 in the denominator
  // The truth itself scores 0; a prediction halfway between start and truth scores 1.
  EXPECT_EQ(MovedErrorRatio(first, real, real)[0], 0.0);
  const Clip halfway = Frames({{kGrey, Rgb{100, 120, 100}, kGrey, Rgb{150, 75, 100}}});
  EXPECT_DOUBLE_EQ(MovedErrorRatio(first, SubClip(real, 0, 1), halfway)[0], 1.0);
}

TEST(FramePsnr, IsTenLogOfPeakSquaredOverMseAndInfiniteForIdenticalFrames) {
  const Clip a = Frames({{kGrey, kGrey, kGrey, kGrey}, {kGrey, kGrey, kGrey, kGrey}});
  const Rgb off = {110, 110, 110};  // 10 levels everywhere: MSE 100
  const Clip b = Frames({{off, off, off, off}, {kGrey, kGrey, kGrey, kGrey}});
  const std::vector<double> p = FramePsnr(a, b);
  EXPECT_NEAR(p[0], 10 * std::log10(255.0 * 255.0 / 100.0), 1e-9);  // 28.1308 dB
  EXPECT_TRUE(std::isinf(p[1]) && p[1] > 0);
}

TEST(DeltaPsnr, IsThePerStepDifferenceAndZeroWhenThePredictionDidNotChange) {
  const std::vector<double> d =
      DeltaPsnr({30, INFINITY, INFINITY, 25, 20}, {28, INFINITY, 40, 25, 22.5});
  ASSERT_EQ(d.size(), 5u);
  EXPECT_EQ(d[0], 2.0);
  EXPECT_EQ(d[1], 0.0);  // the same (perfect) frame with either action sequence
  EXPECT_TRUE(std::isnan(d[2]));
  EXPECT_EQ(d[3], 0.0);
  EXPECT_EQ(d[4], -2.5);  // perturbed actions happened to fit better: negative
  // A static prediction (e.g. copy_last) is the same clip whatever the actions: exactly 0.
  const Clip real = Frames({{kGrey, kGrey, kGrey, Rgb{0, 0, 0}}});
  const Clip copy = Frames({{kGrey, kGrey, kGrey, kGrey}});
  EXPECT_EQ(DeltaPsnr(FramePsnr(real, copy), FramePsnr(real, copy)), std::vector<double>{0.0});
}

}  // namespace
}  // namespace wm::evaluate

// The layered kind's motion prior (motion/motion_prior.h): which pixels count as moved in a
// window, the cross-entropy it pulls the layers' union towards them with, its schedule, and the
// frame loss's weights on those pixels (train.moved_weight). Checked against geometry and
// means worked out by hand.
#include "motion/motion_prior.h"

#include <gtest/gtest.h>

#include <cmath>

namespace wm::motion {
namespace {

constexpr int64_t kSize = 16;

// [1, frames, 3, S, S] of table grey (-0.2) with a bright 3x3 square (0.8) at each (x, y) given.
torch::Tensor SquareWindow(const std::vector<std::pair<int, int>>& corners) {
  torch::Tensor w = torch::full({1, static_cast<int64_t>(corners.size()), 3, kSize, kSize}, -0.2);
  for (size_t f = 0; f < corners.size(); ++f) {
    const auto [x, y] = corners[f];
    w[0][static_cast<int64_t>(f)].narrow(1, y, 3).narrow(2, x, 3).fill_(0.8);
  }
  return w;
}

// 1 on the 3x3 squares at the given corners, each grown by a pixel (a 5x5 box), else 0.
torch::Tensor GrownSquares(const std::vector<std::pair<int, int>>& corners) {
  torch::Tensor m = torch::zeros({1, kSize, kSize});
  for (const auto& [x, y] : corners) m[0].narrow(0, y - 1, 5).narrow(1, x - 1, 5).fill_(1);
  return m;
}

TEST(MotionPrior, MovedPixelsAreWhereTheSquareWasAndWentAfterTheGivenFrame) {
  // frame 0 (before the given one) has the square elsewhere: it must not count
  const torch::Tensor window = SquareWindow({{10, 10}, {2, 3}, {5, 3}, {8, 4}});
  const torch::Tensor moved = MovedPixels(window, 1);
  ASSERT_EQ(moved.sizes(), torch::IntArrayRef({1, kSize, kSize}));
  EXPECT_TRUE(torch::equal(moved, GrownSquares({{2, 3}, {5, 3}, {8, 4}})));
}

TEST(MotionPrior, ChangesBelowTheThresholdDoNotCount) {
  torch::Tensor window = SquareWindow({{2, 3}, {2, 3}});
  window[0][1] += 25 / 127.5;  // 25 levels everywhere: a lighting change, not motion
  EXPECT_EQ(MovedPixels(window, 0).sum().item<float>(), 0);
  EXPECT_EQ(MovedPixels(window, 0, 20).sum().item<float>(), kSize * kSize);
}

TEST(MotionPriorLoss, IsTheCrossEntropyOfTheLayersUnion) {
  // two layers of 0.5 and 0.2 cover 1 - 0.5 * 0.8 = 0.6 of every pixel
  torch::Tensor masks = torch::empty({1, 2, kSize, kSize});
  masks.select(1, 0).fill_(0.5);
  masks.select(1, 1).fill_(0.2);
  torch::Tensor moved = torch::zeros({1, kSize, kSize});
  moved[0].narrow(0, 0, kSize / 4).fill_(1);  // a quarter of the pixels moved
  const double expected = -(0.25 * std::log(0.6) + 0.75 * std::log(0.4));
  EXPECT_NEAR(MotionPriorLoss(masks, moved).item<double>(), expected, 1e-6);
  // saturated masks on exactly the moved pixels: the clamp keeps it finite and near 0
  const torch::Tensor exact = torch::stack({moved, torch::zeros_like(moved)}, 1);
  EXPECT_LT(MotionPriorLoss(exact, moved).item<double>(), 1e-3);
}

TEST(MovedLossWeights, MakeTheL1AMeanWeightedTowardsTheMovedPixels) {
  const torch::Tensor imagined = torch::zeros({1, 3, kSize, kSize});
  torch::Tensor real = torch::full({1, 3, kSize, kSize}, 0.1);
  torch::Tensor moved = torch::zeros({1, kSize, kSize});
  moved[0].narrow(0, 0, kSize / 4).fill_(1);  // a quarter of the pixels moved
  real.narrow(2, 0, kSize / 4).fill_(0.9);    // and are imagined 0.9 off, the rest 0.1
  // no weights: the plain mean, 0.25 x 0.9 + 0.75 x 0.1
  EXPECT_FALSE(MovedLossWeights(moved, 0).defined());
  EXPECT_NEAR(FrameL1(imagined, real, MovedLossWeights(moved, 0)).item<double>(), 0.3, 1e-6);
  // weight 4: moved pixels count 5, the rest 1: (0.25 x 5 x 0.9 + 0.75 x 0.1) / 2
  const torch::Tensor weights = MovedLossWeights(moved, 4);
  ASSERT_EQ(weights.sizes(), torch::IntArrayRef({1, 1, kSize, kSize}));
  EXPECT_NEAR(weights.mean().item<double>(), 1, 1e-6);
  EXPECT_NEAR(FrameL1(imagined, real, weights).item<double>(), (1.125 + 0.075) / 2, 1e-6);
  // a uniform error is weighed to itself whatever moved
  EXPECT_NEAR(FrameL1(imagined, torch::full_like(real, 0.1), weights).item<double>(), 0.1, 1e-6);
}

TEST(MotionPriorWeight, FadesToZeroOverItsShareOfTheSteps) {
  TrainConfig t;
  t.steps = 1000;
  EXPECT_EQ(MotionPriorWeight(t, 0), 0);  // off by default
  t.motion_prior = 2;
  t.motion_prior_steps = 0.1;
  EXPECT_DOUBLE_EQ(MotionPriorWeight(t, 0), 2);
  EXPECT_DOUBLE_EQ(MotionPriorWeight(t, 50), 1);
  EXPECT_EQ(MotionPriorWeight(t, 100), 0);
  EXPECT_EQ(MotionPriorWeight(t, 999), 0);
}

}  // namespace
}  // namespace wm::motion

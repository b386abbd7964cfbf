// The pose kind's edge term (motion/pose_trainer.h, GradientDifference; train.edge_weight):
// neighbouring-pixel differences of the drawn frame against the real one, worked out by hand.
#include "motion/pose_trainer.h"

#include <gtest/gtest.h>

namespace wm::motion {
namespace {

constexpr int64_t kSize = 8;

// [1, 3, S, S] of `low` left of column `edge` and `high` from it on: a vertical edge.
torch::Tensor VerticalEdge(double low, double high, int64_t edge) {
  torch::Tensor x = torch::full({1, 3, kSize, kSize}, low);
  x.narrow(3, edge, kSize - edge).fill_(high);
  return x;
}

double AbsSum(const torch::Tensor& x) { return x.abs().sum().item<double>(); }

TEST(GradientDifference, HasOneMapPerAxisOneShorterAlongIt) {
  const std::vector<torch::Tensor> d =
      GradientDifference(torch::zeros({2, 3, 5, 7}), torch::zeros({2, 3, 5, 7}));
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d[0].sizes(), torch::IntArrayRef({2, 3, 5, 6}));
  EXPECT_EQ(d[1].sizes(), torch::IntArrayRef({2, 3, 4, 7}));
}

// What the pixel L1 punishes and the edge term does not: the same picture a shade brighter.
TEST(GradientDifference, IgnoresAUniformShiftOfBrightness) {
  const torch::Tensor real = VerticalEdge(-0.5, 0.5, 4);
  for (const torch::Tensor& d : GradientDifference(real + 0.3, real)) EXPECT_EQ(AbsSum(d), 0);
}

// What it punishes and the pixel L1 hardly sees: an edge smeared over four pixels.
TEST(GradientDifference, ChargesABlurredEdgeWhatItLostOfTheStep) {
  const torch::Tensor real = VerticalEdge(-0.5, 0.5, 4);
  torch::Tensor blurred = real.clone();  // -0.5, -0.5, -0.25, 0, 0.25, 0.5, ... along each row
  blurred.select(3, 2).fill_(-0.25);
  blurred.select(3, 3).fill_(0);
  blurred.select(3, 4).fill_(0.25);
  const std::vector<torch::Tensor> d = GradientDifference(blurred, real);
  // Along x, per row and channel: steps of 0.25 at columns 1-2, 2-3, 3-4, 4-5 against the real
  // 0, 0, 1, 0: |0.25| + |0.25| + |0.25 - 1| + |0.25| = 1.5; along y nothing changes.
  EXPECT_NEAR(AbsSum(d[0]), 1.5 * 3 * kSize, 1e-5);
  EXPECT_EQ(AbsSum(d[1]), 0);
  // The pixel L1 of the same blur: 0.25 + 0.5 + 0.25 per row and channel, no more than the
  // edge term's; an edge one pixel off costs the edge term 2 per row (|1| + |-1|).
  EXPECT_NEAR(AbsSum(blurred - real), 1.0 * 3 * kSize, 1e-5);
  EXPECT_NEAR(AbsSum(GradientDifference(VerticalEdge(-0.5, 0.5, 5), real)[0]), 2.0 * 3 * kSize,
              1e-5);
}

}  // namespace
}  // namespace wm::motion

// The pose kind's edge term (motion/pose_trainer.h, GradientDifference; train.edge_weight):
// neighbouring-pixel differences of the drawn frame against the real one, worked out by hand;
// and the alpha's calibration (FitAlphaShift) against rollouts through the model's own Advance.
#include "motion/pose_trainer.h"

#include <gtest/gtest.h>

#include <limits>

#include "motion/motion_net.h"
#include "motion/pose_net.h"
#include "tests/core/test_util.h"
#include "tests/motion/moving_square.h"

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

// The moving-square test config's frame size (test::TestConfig).
const int64_t kSquaresSize = test::TestConfig().model.image_size;

// A pose net of the moving-square test config, the same weights for the same seed.
PoseNet SquaresPoseNet(int64_t action_dim) {
  torch::manual_seed(3);
  ModelConfig model = test::TestConfig().model;
  model.kind = "pose";
  model.pose_dim = 4;
  model.renderer_width = 8;
  return PoseNet(model, action_dim);
}

// The mean squared error of `net`'s rollouts from the episodes' first frames, through Advance.
double RolloutMse(PoseNet& net, const WindowSampler& sampler, const std::vector<EpisodeClip>& clips) {
  torch::NoGradGuard no_grad;
  double sum = 0;
  int64_t count = 0;
  for (const EpisodeClip& clip : clips) {
    const ClipTensors t = RolloutTensors(clip, sampler.action_norm(), kSquaresSize);
    PoseRollout r = net->Start(t.frames.slice(0, 0, 1));
    for (int64_t i = 0; i < t.actions.size(0); ++i) {
      const torch::Tensor next = net->Advance(r, t.actions.slice(0, i, i + 1));
      sum += (next - t.frames.slice(0, i + 1, i + 2)).square().sum().item<double>();
      count += next.numel();
    }
  }
  return sum / static_cast<double>(count);
}

// The shift it keeps is the one, of -2 to 2 in eighths, whose rollouts (the model's Advance,
// with the shift applied to a fresh copy of the net) match the episodes best; the net is left
// shifted by it, and its rollouts then score what the fit reports.
TEST(FitAlphaShift, KeepsTheShiftWhoseRolloutsMatchBest) {
  wm::test::TempDir dir;
  test::WriteMovingSquares(dir / "train", 6, 9, 1);
  const int64_t unroll = 4;
  const WindowSampler sampler(dir / "train", "image", kSquaresSize, unroll);
  const std::vector<EpisodeClip> clips = sampler.Episodes(64, unroll + 1);
  double best_shift = 0, best_mse = std::numeric_limits<double>::infinity(), unshifted = 0;
  for (int i = 0; i <= 32; ++i) {
    const double shift = -2 + i / 8.0;
    PoseNet net = SquaresPoseNet(sampler.action_dim());
    net->renderer()->ShiftAlpha(shift);
    const double mse = RolloutMse(net, sampler, clips);
    if (shift == 0) unshifted = mse;
    if (mse < best_mse) best_shift = shift, best_mse = mse;
  }
  PoseNet net = SquaresPoseNet(sampler.action_dim());
  const AlphaShiftFit fit = FitAlphaShift(net, sampler, unroll, kSquaresSize, torch::kCPU);
  EXPECT_EQ(fit.episodes, 6);
  EXPECT_DOUBLE_EQ(fit.shift, best_shift);
  EXPECT_NEAR(fit.mse_before, unshifted, 1e-6);
  EXPECT_NEAR(fit.mse_after, best_mse, 1e-6);
  EXPECT_NEAR(RolloutMse(net, sampler, clips), best_mse, 1e-6);
  EXPECT_LT(fit.mse_after, fit.mse_before);  // a random renderer is not calibrated
}

}  // namespace
}  // namespace wm::motion

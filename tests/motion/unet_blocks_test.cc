// UpConv (motion/unet_blocks.h): PyTorch's ConvTranspose2d(in, out, 4, stride 2, padding 1)
// computed phase by phase. Checked against ATen's own transposed convolution: the same initial
// parameters under their names, the same outputs and the same gradients to float rounding.
#include "motion/unet_blocks.h"

#include <gtest/gtest.h>

namespace wm::motion {
namespace {

double MaxAbsDifference(const torch::Tensor& a, const torch::Tensor& b) {
  return (a - b).abs().max().item<double>();
}

TEST(UpConv, StartsWithConvTranspose2dsParametersUnderItsNames) {
  torch::manual_seed(7);
  torch::nn::ConvTranspose2d reference(
      torch::nn::ConvTranspose2dOptions(6, 5, 4).stride(2).padding(1));
  torch::manual_seed(7);
  UpConv up(6, 5);
  const auto want = reference->named_parameters(), got = up->named_parameters();
  ASSERT_EQ(got.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) {
    EXPECT_EQ(got[i].key(), want[i].key());
    EXPECT_TRUE(torch::equal(got[i].value(), want[i].value())) << want[i].key();
  }
}

// Odd and even sizes, non-square, batch 2: each output pixel's four taps and the borders.
TEST(UpConv, OutputsAndGradientsAreThoseOfATransposedConvolution) {
  torch::manual_seed(3);
  UpConv up(4, 3);
  for (const auto& [h, w] : std::vector<std::pair<int64_t, int64_t>>{{5, 7}, {8, 8}, {1, 2}}) {
    const torch::Tensor x = torch::randn({2, 4, h, w}, torch::requires_grad());
    const torch::Tensor probe = torch::randn({2, 3, 2 * h, 2 * w});
    const torch::Tensor got = up->forward(x), want = up->TransposedConvolution(x);
    ASSERT_EQ(got.sizes(), want.sizes());
    EXPECT_LT(MaxAbsDifference(got, want), 1e-5) << h << "x" << w;
    const auto got_grads = torch::autograd::grad({(got * probe).sum()}, {x, up->weight, up->bias});
    const auto want_grads =
        torch::autograd::grad({(want * probe).sum()}, {x, up->weight, up->bias});
    for (size_t i = 0; i < got_grads.size(); ++i)
      EXPECT_LT(MaxAbsDifference(got_grads[i], want_grads[i]), 1e-4) << h << "x" << w << " #" << i;
  }
}

// A wrong tap would still give the right shapes: a kernel with one non-zero entry must put the
// input where a transposed convolution puts it (exact: one product per output pixel).
TEST(UpConv, EachKernelTapLandsWhereATransposedConvolutionPutsIt) {
  UpConv up(1, 1);
  torch::NoGradGuard no_grad;
  up->bias.zero_();
  const torch::Tensor x = torch::arange(1, 13, torch::kFloat).view({1, 1, 3, 4});
  for (int64_t ky = 0; ky < 4; ++ky) {
    for (int64_t kx = 0; kx < 4; ++kx) {
      up->weight.zero_();
      up->weight[0][0][ky][kx] = 1;
      EXPECT_TRUE(torch::equal(up->forward(x), up->TransposedConvolution(x))) << ky << "," << kx;
    }
  }
}

}  // namespace
}  // namespace wm::motion

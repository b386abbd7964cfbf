#include "motion/unet_blocks.h"

namespace wm::motion {
namespace {

namespace F = torch::nn::functional;

}  // namespace

UpConvImpl::UpConvImpl(int64_t in, int64_t out) {
  // Drawn by ConvTranspose2d itself: the same random numbers, in the same order, as before.
  torch::nn::ConvTranspose2d init(
      torch::nn::ConvTranspose2dOptions(in, out, 4).stride(2).padding(1));
  weight = register_parameter("weight", init->weight.detach().clone());
  bias = register_parameter("bias", init->bias.detach().clone());
}

torch::Tensor UpConvImpl::TransposedConvolution(const torch::Tensor& x) const {
  return F::conv_transpose2d(x, weight,
                             F::ConvTranspose2dFuncOptions().bias(bias).stride(2).padding(1));
}

// Output row 2i + phase of a 4x4 stride-2 padding-1 transposed convolution sums input rows i - 1
// and i (phase 0: kernel rows 3, 1) or i and i + 1 (phase 1: kernel rows 2, 0); with the input
// padded by one, phase p reads padded rows p + i and p + i + 1. The same holds for columns. In
// the kernel flipped along both axes, phase p's rows (and columns) are every second from p.
torch::Tensor UpConvImpl::forward(const torch::Tensor& x) {
  if (!x.device().is_cpu()) return TransposedConvolution(x);  // cuDNN's is fast
  const int64_t H = x.size(2), W = x.size(3);
  const torch::Tensor padded = F::pad(x, F::PadFuncOptions({1, 1, 1, 1}));
  const torch::Tensor flipped = weight.flip({2, 3});
  std::vector<torch::Tensor> phases;
  for (int64_t row = 0; row < 2; ++row) {
    for (int64_t col = 0; col < 2; ++col) {
      const torch::Tensor kernel =
          flipped.slice(2, row, 4, 2).slice(3, col, 4, 2).transpose(0, 1);  // [out, in, 2, 2]
      phases.push_back(F::conv2d(padded.slice(2, row, row + H + 1).slice(3, col, col + W + 1),
                                 kernel, F::Conv2dFuncOptions().bias(bias)));
    }
  }
  // [B, out, 4, H, W] -> [B, out, 2H, 2W]: channel o's phases (row, col) at (2i + row, 2j + col).
  return torch::pixel_shuffle(torch::stack(phases, 2).flatten(1, 2), 2);
}

}  // namespace wm::motion

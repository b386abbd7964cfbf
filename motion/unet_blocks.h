#pragma once
// The convolution blocks the motion model's nets are built of (warp_net.cc, layer_net.cc,
// pose_net.cc), under the PyTorch twin's module layout (tests/motion/warp_twin.py: down, up).
// Internal.
#include <torch/torch.h>

namespace wm::motion {

// A 4x4 stride-2 convolution and a ReLU: halves the resolution.
inline torch::nn::Sequential Down(int64_t in, int64_t out) {
  return torch::nn::Sequential(
      torch::nn::Conv2d(torch::nn::Conv2dOptions(in, out, 4).stride(2).padding(1)),
      torch::nn::ReLU());
}

// PyTorch's ConvTranspose2d(in, out, 4, stride 2, padding 1): its parameters (the same names,
// shapes and initial values), its sums. On a CPU each of the four output pixel phases is a 2x2
// convolution of the input, interleaved: LibTorch 1.13 has no MKL-DNN transposed convolution,
// and its fallback took about twice as long forward and backward at the eraser's largest
// (bench/motion_blocks_bench.cc). Results equal ConvTranspose2d's to float rounding, not bit for
// bit.
class UpConvImpl : public torch::nn::Module {
 public:
  UpConvImpl(int64_t in, int64_t out);
  torch::Tensor forward(const torch::Tensor& x);
  // ATen's conv_transpose2d with these parameters: forward's path off the CPU, and the reference
  // unet_blocks_test and bench/motion_blocks_bench check the phases against.
  torch::Tensor TransposedConvolution(const torch::Tensor& x) const;

  torch::Tensor weight;  // [in, out, 4, 4], ConvTranspose2d's layout
  torch::Tensor bias;    // [out]
};
TORCH_MODULE(UpConv);

// A 4x4 stride-2 transposed convolution (UpConv) and a ReLU: doubles the resolution.
inline torch::nn::Sequential Up(int64_t in, int64_t out) {
  return torch::nn::Sequential(UpConv(in, out), torch::nn::ReLU());
}

// `levels` halvings (4x4 stride-2 convolutions and ReLUs, `in` then `c` channels) as one flat
// Sequential: LibTorch cannot nest Sequentials.
inline torch::nn::Sequential Downs(int64_t in, int64_t c, int levels) {
  torch::nn::Sequential stack;
  for (int level = 0; level < levels; ++level) {
    stack->push_back(torch::nn::Conv2d(
        torch::nn::Conv2dOptions(level == 0 ? in : c, c, 4).stride(2).padding(1)));
    stack->push_back(torch::nn::ReLU());
  }
  return stack;
}

inline torch::nn::Conv2d Conv3x3(int64_t in, int64_t out) {
  return torch::nn::Conv2d(torch::nn::Conv2dOptions(in, out, 3).padding(1));
}

}  // namespace wm::motion

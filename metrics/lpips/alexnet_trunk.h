#pragma once
// torchvision alexnet().features up to relu5 (its final max-pool, index 12, is not used), tapped
// where lpips.pretrained_networks.alexnet cuts its slices: after indices 1, 4, 7, 9, 11. Internal
// to wm_lpips (includes LibTorch).
#include <torch/torch.h>

#include <array>

#include "metrics/lpips/lpips.h"

namespace wm::metrics {

struct AlexNetTrunkImpl : torch::nn::Module {
  AlexNetTrunkImpl();

  // x: [N, 3, H, W] float -> relu1..relu5, each [N, C, h, w] dense and contiguous.
  std::array<torch::Tensor, kLpipsLayers> forward(const torch::Tensor& x);

  // Call once the weights are loaded, on the CPU; without oneDNN it changes nothing. Measured
  // (docs/metrics-lpips.md, "Speed"), oneDNN runs the two image sizes best in different ways:
  // - small images (up to kBlockedMaxPixels): conv weights reordered into oneDNN's blocked layout
  //   once, activations kept in that layout between layers. The dense path reorders weights, input
  //   and output on every convolution, most of a pass at 64x64.
  // - larger images: dense channels-last tensors (weights converted once), which oneDNN runs with
  //   its faster NHWC kernels (brgconv) when the compute dominates.
  void PrepareForCpu();
  static constexpr int64_t kBlockedMaxPixels = 128 * 128;

  std::array<torch::nn::Conv2d, kLpipsLayers> convs{nullptr, nullptr, nullptr, nullptr,
                                                    nullptr};  // conv1..conv5

 private:
  torch::Tensor Convolve(int layer, const torch::Tensor& x, bool blocked);
  std::array<torch::Tensor, kLpipsLayers> packed_weights_;  // oneDNN layout; empty if not packed
};
TORCH_MODULE(AlexNetTrunk);

}  // namespace wm::metrics

#pragma once
// The arithmetic around LPIPS's AlexNet trunk as single passes over CPU memory: the scaled input
// batch and the normalise / difference / lin / spatial-mean reduction of each layer. The torch-op
// chains they replace made several full-size temporaries per step, which cost most of a pass at
// 64x64 (docs/metrics-lpips.md, "Speed"). Internal to wm_lpips (includes LibTorch).
#include <torch/torch.h>

#include <array>
#include <cstdint>
#include <vector>

namespace wm::metrics {

// lpips.ScalingLayer s(x) = (x - shift) / scale per RGB channel, for float inputs in [-1, 1] and,
// through a table, for uint8 inputs first mapped as x / 127.5 - 1 (lpips.im2tensor).
class InputScaling {
 public:
  // shift, scale: [1, 3, 1, 1] float CPU (the ScalingLayer buffers).
  InputScaling(const torch::Tensor& shift, const torch::Tensor& scale);
  float operator()(int channel, float x) const { return (x - shift_[channel]) / scale_[channel]; }
  float operator()(int channel, uint8_t x) const { return of_byte_[channel][x]; }

 private:
  std::array<float, 3> shift_{}, scale_{};
  std::array<std::array<float, 256>, 3> of_byte_{};
};

// images: N pointers to H x W x 3 interleaved RGB -> s(image), [N, 3, H, W] float on the CPU,
// channels-last (the pixels keep their interleaved order).
torch::Tensor ScaledBatch(const std::vector<const uint8_t*>& images, int height, int width,
                          const InputScaling& scaling);
torch::Tensor ScaledBatch(const std::vector<const float*>& images, int height, int width,
                          const InputScaling& scaling);

// One layer's LPIPS v0.1 term of each pair, the pairs being rows (i, B + i) of `features`
// ([2B, C, h, w] float CPU) and n(f) = f / (sqrt(sum_c f^2) + eps):
//   term_i = mean_hw sum_c lin_c (n(f_i) - n(f_{B+i}))_c^2       (lin: [1, C, 1, 1], >= 0)
// Returns [B] float64. Equal rows give exactly 0.
torch::Tensor LayerTerms(const torch::Tensor& features, const torch::Tensor& lin, double eps);

}  // namespace wm::metrics

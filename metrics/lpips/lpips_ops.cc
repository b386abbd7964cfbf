#include "metrics/lpips/lpips_ops.h"

#include <ATen/Parallel.h>

#include <algorithm>
#include <cmath>

namespace wm::metrics {

InputScaling::InputScaling(const torch::Tensor& shift, const torch::Tensor& scale) {
  // The byte table comes from the same torch ops the per-pixel chain ran, so it is bit-identical.
  const torch::Tensor bytes = torch::arange(256, torch::kFloat32).view({1, 1, 1, 256});
  const torch::Tensor table = ((bytes / 127.5 - 1.0) - shift) / scale;  // [1, 3, 1, 256]
  const torch::Tensor flat = table.contiguous();
  for (int c = 0; c < 3; ++c) {
    shift_[c] = shift.view({3})[c].item<float>();
    scale_[c] = scale.view({3})[c].item<float>();
    std::copy_n(flat.data_ptr<float>() + c * 256, 256, of_byte_[c].begin());
  }
}

namespace {

// HWC -> CHW with the scaling applied on the way, one image per task.
template <typename T>
torch::Tensor ScaledPlanes(const std::vector<const T*>& images, int height, int width,
                           const InputScaling& scaling) {
  const int64_t count = static_cast<int64_t>(images.size()), plane = int64_t{height} * width;
  torch::Tensor out = torch::empty({count, 3, height, width}, torch::kFloat32);
  float* const dst = out.data_ptr<float>();
  at::parallel_for(0, count, 1, [&](int64_t first, int64_t last) {
    for (int64_t i = first; i < last; ++i) {
      const T* src = images[i];
      float* const planes = dst + i * 3 * plane;
      for (int64_t p = 0; p < plane; ++p) {
        for (int c = 0; c < 3; ++c) planes[c * plane + p] = scaling(c, src[p * 3 + c]);
      }
    }
  });
  return out;
}

// out[p] = 1 / (sqrt(sum_c f[c, p]^2) + eps); channel-outer so the inner loop vectorises.
void InverseNorms(const float* f, int64_t channels, int64_t positions, float eps, float* out) {
  std::fill_n(out, positions, 0.0f);
  for (int64_t c = 0; c < channels; ++c) {
    const float* row = f + c * positions;
    for (int64_t p = 0; p < positions; ++p) out[p] += row[p] * row[p];
  }
  for (int64_t p = 0; p < positions; ++p) out[p] = 1.0f / (std::sqrt(out[p]) + eps);
}

}  // namespace

torch::Tensor ScaledBatch(const std::vector<const uint8_t*>& images, int height, int width,
                          const InputScaling& scaling) {
  return ScaledPlanes(images, height, width, scaling);
}

torch::Tensor ScaledBatch(const std::vector<const float*>& images, int height, int width,
                          const InputScaling& scaling) {
  return ScaledPlanes(images, height, width, scaling);
}

torch::Tensor LayerTerms(const torch::Tensor& features, const torch::Tensor& lin, double eps) {
  TORCH_CHECK(features.is_cpu() && features.scalar_type() == torch::kFloat32 &&
              features.dim() == 4 && features.size(0) % 2 == 0);
  const torch::Tensor f = features.contiguous(), w = lin.contiguous();
  const int64_t batch = f.size(0) / 2, channels = f.size(1), positions = f.size(2) * f.size(3);
  TORCH_CHECK(w.numel() == channels);
  torch::Tensor terms = torch::empty({batch}, torch::kFloat64);
  const float* const data = f.data_ptr<float>();
  const float* const weight = w.data_ptr<float>();
  double* const out = terms.data_ptr<double>();
  at::parallel_for(0, batch, 1, [&](int64_t first, int64_t last) {
    std::vector<float> inv0(positions), inv1(positions), weighted(positions);
    for (int64_t i = first; i < last; ++i) {
      const float* f0 = data + i * channels * positions;
      const float* f1 = data + (batch + i) * channels * positions;
      InverseNorms(f0, channels, positions, static_cast<float>(eps), inv0.data());
      InverseNorms(f1, channels, positions, static_cast<float>(eps), inv1.data());
      // lin is linear, so it is applied per position before the spatial mean (the 1x1 conv).
      std::fill(weighted.begin(), weighted.end(), 0.0f);
      for (int64_t c = 0; c < channels; ++c) {
        const float* r0 = f0 + c * positions;
        const float* r1 = f1 + c * positions;
        for (int64_t p = 0; p < positions; ++p) {
          const float d = r0[p] * inv0[p] - r1[p] * inv1[p];
          weighted[p] += weight[c] * d * d;
        }
      }
      double sum = 0.0;
      for (const float v : weighted) sum += v;
      out[i] = sum / static_cast<double>(positions);
    }
  });
  return terms;
}

}  // namespace wm::metrics

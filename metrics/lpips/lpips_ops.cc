#include "metrics/lpips/lpips_ops.h"

#include <ATen/Parallel.h>

#include <algorithm>
#include <cmath>

namespace wm::metrics {

InputScaling::InputScaling(const torch::Tensor& shift, const torch::Tensor& scale) {
  // The table comes from the float ops the per-pixel chain ran, in the same order, so uint8 inputs
  // reach conv1 as before.
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

// The interleaved pixels keep their order: the batch is channels-last, which the CPU convolutions
// run fastest on large images (see AlexNetTrunkImpl).
template <typename T>
torch::Tensor ScaledPixels(const std::vector<const T*>& images, int height, int width,
                           const InputScaling& scaling) {
  const int64_t count = static_cast<int64_t>(images.size()), pixels = int64_t{height} * width;
  torch::Tensor out = torch::empty(
      {count, 3, height, width},
      torch::TensorOptions(torch::kFloat32).memory_format(at::MemoryFormat::ChannelsLast));
  float* const dst = out.data_ptr<float>();
  at::parallel_for(0, count, 1, [&](int64_t first, int64_t last) {
    for (int64_t i = first; i < last; ++i) {
      const T* src = images[i];
      float* const image = dst + i * 3 * pixels;
      for (int64_t p = 0; p < 3 * pixels; p += 3) {
        for (int c = 0; c < 3; ++c) image[p + c] = scaling(c, src[p + c]);
      }
    }
  });
  return out;
}

// sum_{k < n} term(k) in kLanes partial sums, a form the compiler vectorises (a plain float sum
// it may not reorder).
template <typename Term>
float LaneSum(int64_t n, Term term) {
  constexpr int kLanes = 8;
  std::array<float, kLanes> lanes{};
  int64_t k = 0;
  for (; k + kLanes <= n; k += kLanes) {
    for (int l = 0; l < kLanes; ++l) lanes[l] += term(k + l);
  }
  float sum = 0.0f;
  for (; k < n; ++k) sum += term(k);
  for (const float v : lanes) sum += v;
  return sum;
}

// One pair with channels contiguous per position ([P, C] each).
double PairTermChannelsLast(const float* f0, const float* f1, const float* w, int64_t channels,
                            int64_t positions, float eps) {
  double sum = 0.0;
  for (int64_t p = 0; p < positions; ++p) {
    const float* a = f0 + p * channels;
    const float* b = f1 + p * channels;
    const float inv_a =
        1.0f / (std::sqrt(LaneSum(channels, [a](int64_t c) { return a[c] * a[c]; })) + eps);
    const float inv_b =
        1.0f / (std::sqrt(LaneSum(channels, [b](int64_t c) { return b[c] * b[c]; })) + eps);
    sum += LaneSum(channels, [&](int64_t c) {
      const float d = a[c] * inv_a - b[c] * inv_b;
      return w[c] * d * d;
    });
  }
  return sum / static_cast<double>(positions);
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

struct ChannelsFirstScratch {
  explicit ChannelsFirstScratch(int64_t positions)
      : inv_a(positions), inv_b(positions), weighted(positions) {}
  std::vector<float> inv_a, inv_b, weighted;
};

// One pair with each channel contiguous ([C, P] each). lin is a 1x1 conv without bias, so it is
// applied per position before the spatial mean and no difference map is stored.
double PairTermChannelsFirst(const float* f0, const float* f1, const float* w, int64_t channels,
                             int64_t positions, float eps, ChannelsFirstScratch& s) {
  InverseNorms(f0, channels, positions, eps, s.inv_a.data());
  InverseNorms(f1, channels, positions, eps, s.inv_b.data());
  std::fill(s.weighted.begin(), s.weighted.end(), 0.0f);
  for (int64_t c = 0; c < channels; ++c) {
    const float* a = f0 + c * positions;
    const float* b = f1 + c * positions;
    for (int64_t p = 0; p < positions; ++p) {
      const float d = a[p] * s.inv_a[p] - b[p] * s.inv_b[p];
      s.weighted[p] += w[c] * d * d;
    }
  }
  double sum = 0.0;
  for (const float v : s.weighted) sum += v;
  return sum / static_cast<double>(positions);
}

}  // namespace

torch::Tensor ScaledBatch(const std::vector<const uint8_t*>& images, int height, int width,
                          const InputScaling& scaling) {
  return ScaledPixels(images, height, width, scaling);
}

torch::Tensor ScaledBatch(const std::vector<const float*>& images, int height, int width,
                          const InputScaling& scaling) {
  return ScaledPixels(images, height, width, scaling);
}

torch::Tensor LayerTerms(const torch::Tensor& features, const torch::Tensor& lin, double eps) {
  TORCH_CHECK(features.is_cpu() && features.scalar_type() == torch::kFloat32 &&
              features.dim() == 4 && features.size(0) % 2 == 0);
  const bool channels_last =
      !features.is_contiguous() && features.is_contiguous(at::MemoryFormat::ChannelsLast);
  const torch::Tensor f = channels_last ? features : features.contiguous();
  const torch::Tensor w = lin.contiguous();
  const int64_t batch = f.size(0) / 2, channels = f.size(1), positions = f.size(2) * f.size(3);
  TORCH_CHECK(w.numel() == channels);
  torch::Tensor terms = torch::empty({batch}, torch::kFloat64);
  const float* const data = f.data_ptr<float>();
  const float* const weight = w.data_ptr<float>();
  const auto epsf = static_cast<float>(eps);
  double* const out = terms.data_ptr<double>();
  at::parallel_for(0, batch, 1, [&](int64_t first, int64_t last) {
    ChannelsFirstScratch scratch(channels_last ? 0 : positions);
    for (int64_t i = first; i < last; ++i) {
      const float* f0 = data + i * channels * positions;
      const float* f1 = data + (batch + i) * channels * positions;
      out[i] = channels_last
                   ? PairTermChannelsLast(f0, f1, weight, channels, positions, epsf)
                   : PairTermChannelsFirst(f0, f1, weight, channels, positions, epsf, scratch);
    }
  });
  return terms;
}

}  // namespace wm::metrics

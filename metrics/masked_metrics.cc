#include "metrics/masked_metrics.h"

#include <cmath>
#include <vector>

#include "core/error.h"
#include "metrics/pixel_metrics.h"

namespace wm::metrics {

MaskedMetrics CompareMasked(const Image& a, const Image& b, const Image& mask, bool ssim,
                            int threads) {
  CheckSameShape(a, b);
  Check(mask.height == a.height && mask.width == a.width,
        "mask is " + ShapeString(mask) + ", the frames " + ShapeString(a));
  std::vector<bool> inside(static_cast<size_t>(a.height) * a.width, false);
  for (size_t p = 0; p < inside.size(); ++p) {
    for (int c = 0; c < mask.channels; ++c)
      inside[p] = inside[p] || mask.pixels[p * mask.channels + c] != 0;
  }
  MaskedMetrics out;
  double squared = 0;
  for (size_t p = 0; p < inside.size(); ++p) {
    if (!inside[p]) continue;
    ++out.pixels;
    for (int c = 0; c < a.channels; ++c) {
      const double d = a.pixels[p * a.channels + c] - b.pixels[p * a.channels + c];
      squared += d * d;
    }
  }
  if (out.pixels == 0) {
    out.mse = out.psnr = out.ssim = NAN;
    return out;
  }
  out.mse = squared / (static_cast<double>(out.pixels) * a.channels);
  out.psnr = PsnrFromMse(out.mse, a.data_range);
  out.ssim = NAN;
  if (!ssim) return out;
  Image map;
  Ssim(a, b, &map, threads);
  double sum = 0;
  int64_t n = 0;
  for (int y = kSsimCrop; y < a.height - kSsimCrop; ++y) {
    for (int x = kSsimCrop; x < a.width - kSsimCrop; ++x) {
      const size_t p = static_cast<size_t>(y) * a.width + x;
      if (!inside[p]) continue;
      for (int c = 0; c < a.channels; ++c) sum += map.pixels[p * a.channels + c];
      n += a.channels;
    }
  }
  if (n > 0) out.ssim = sum / static_cast<double>(n);
  return out;
}

}  // namespace wm::metrics

#include "tokenize/validation.h"

#include <cmath>

#include "metrics/image.h"
#include "metrics/pixel_metrics.h"
#include "tokenize/tokenizer.h"

namespace wm::tokenize {

ReconstructionScore ScoreReconstruction(const float* original, const float* recon, int64_t n,
                                        int size) {
  const size_t floats = 3ull * size * size;
  ReconstructionScore score;
  int64_t finite = 0;
  double l1 = 0;
  for (int64_t i = 0; i < n; ++i) {
    const float* a = original + i * floats;
    const float* b = recon + i * floats;
    for (size_t j = 0; j < floats; ++j) l1 += std::abs(std::clamp(b[j], -1.f, 1.f) - a[j]);
    auto ref = metrics::Image::FromUint8(PlanarToRgb8(a, size).data(), size, size, 3);
    auto pred = metrics::Image::FromUint8(PlanarToRgb8(b, size).data(), size, size, 3);
    const double psnr = metrics::Psnr(ref, pred);
    if (std::isfinite(psnr)) {
      score.psnr += psnr;
      ++finite;
    }
    score.ssim += metrics::Ssim(ref, pred);
  }
  score.psnr = finite ? score.psnr / finite : INFINITY;
  score.ssim /= static_cast<double>(n);
  score.l1 = l1 / (static_cast<double>(n) * floats);
  return score;
}

}  // namespace wm::tokenize

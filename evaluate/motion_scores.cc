#include "evaluate/motion_scores.h"

#include <cmath>
#include <cstdlib>

#include "core/error.h"
#include "metrics/image.h"
#include "metrics/pixel_metrics.h"
#include "tokenize/tokenizer.h"
#include "tokenize/validation.h"

namespace wm::evaluate {

std::vector<double> FramePsnr(const Clip& real, const Clip& pred) {
  Check(real.frames == pred.frames && real.size == pred.size, "clips differ in shape");
  std::vector<double> out;
  for (int64_t t = 0; t < real.frames; ++t)
    out.push_back(metrics::Psnr(FrameImage(real, t), FrameImage(pred, t)));
  return out;
}

std::vector<double> DeltaPsnr(const std::vector<double>& psnr,
                              const std::vector<double>& psnr_perturbed) {
  Check(psnr.size() == psnr_perturbed.size(), "PSNR series differ in length");
  std::vector<double> out;
  for (size_t t = 0; t < psnr.size(); ++t) {
    const double a = psnr[t], b = psnr_perturbed[t];
    // inf - inf is NaN; the same frame on both sides is no difference.
    out.push_back(a == b ? 0.0 : std::isfinite(a) && std::isfinite(b) ? a - b : NAN);
  }
  return out;
}

std::vector<double> MovedErrorRatio(const Clip& first, const Clip& real, const Clip& pred) {
  Check(real.frames == pred.frames && real.size == pred.size && first.size == real.size &&
            first.frames >= 1,
        "clips differ in shape");
  const int s = real.size;
  const size_t pixels = static_cast<size_t>(s) * s;
  const std::vector<uint8_t> start = tokenize::PlanarToRgb8(first.frame(0), s);
  std::vector<double> out;
  for (int64_t t = 0; t < real.frames; ++t) {
    const std::vector<uint8_t> truth = tokenize::PlanarToRgb8(real.frame(t), s);
    const std::vector<uint8_t> guess = tokenize::PlanarToRgb8(pred.frame(t), s);
    double to_truth = 0, to_start = 0;
    int64_t moved = 0;
    for (size_t p = 0; p < pixels; ++p) {  // interleaved RGB: 3 bytes per pixel
      const size_t i = 3 * p;
      if (!tokenize::PixelChanged(&truth[i], &start[i])) continue;
      ++moved;
      for (size_t c = 0; c < 3; ++c) {
        to_truth += std::abs(guess[i + c] - truth[i + c]);
        to_start += std::abs(guess[i + c] - start[i + c]);
      }
    }
    out.push_back(moved > 0 && to_start > 0 ? to_truth / to_start : NAN);
  }
  return out;
}

}  // namespace wm::evaluate

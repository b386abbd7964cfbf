#pragma once
// Pixel metrics restricted to a region mask (`wm-metrics --mask`): how well a prediction matches
// inside, e.g., the arm's pixels, for any mask a user has. Segmented MSE by named region (arm /
// object / background) with mask sources is metrics/segmentation/segmented_mse.h.
#include <cstdint>

#include "metrics/image.h"

namespace wm::metrics {

struct MaskedMetrics {
  double mse = 0;      // mean squared error over the mask's pixels and every channel
  double psnr = 0;     // PsnrFromMse(mse, data range)
  double ssim = 0;     // mean of the SSIM map (Ssim's) over the mask's pixels inside the
                       // kSsimCrop border, over every channel; NaN when none is inside
  int64_t pixels = 0;  // mask pixels (all three metrics are NaN when 0)
};

// `mask`: one channel (or more: a pixel is inside when any channel is non-zero), the frames'
// height and width. Throws wm::Error on a shape mismatch.
MaskedMetrics CompareMasked(const Image& a, const Image& b, const Image& mask, bool ssim,
                            int threads = 1);

}  // namespace wm::metrics

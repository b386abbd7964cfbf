#pragma once
// Pixel metrics between a predicted and a reference frame: MSE, PSNR, SSIM (Wang et al. 2004,
// matching scikit-image 0.19) and MS-SSIM (Wang et al. 2003), per frame and over videos.
// The exact definitions, constants and edge cases are in docs/metrics.md.
#include <nlohmann/json_fwd.hpp>
#include <vector>

#include "metrics/image.h"

namespace wm::metrics {

// `threads` everywhere: worker threads including the caller's; 0 = all hardware threads.
// Results do not depend on it (work is split into items summed in a fixed order).

// Mean of (a - b)^2 over every pixel and channel.
double Mse(const Image& a, const Image& b);

// 10 log10(R^2 / MSE) in dB with R = data_range; +infinity when MSE is 0 (identical frames).
double Psnr(const Image& a, const Image& b);
double PsnrFromMse(double mse, double data_range);

// Smallest side SSIM accepts: the 11x11 Gaussian window must fit (as in scikit-image).
constexpr int kSsimMinSide = 11;
// Pixels left out of SSIM's mean at each border: (11 - 1) / 2, scikit-image's crop.
constexpr int kSsimCrop = 5;

// Mean SSIM over the image without its kSsimCrop-pixel border, averaged over channels; 1 for
// identical images. When `map` is not null it receives the per-pixel SSIM, HxWxC (border
// included, data_range 1). Throws wm::Error on mismatched shapes or a side below 11.
double Ssim(const Image& a, const Image& b, Image* map = nullptr, int threads = 1);

// MS-SSIM over 5 scales (Wang et al. 2003, eq. 7): prod_{j<5} cs_j^w_j * ssim_5^w_5 with the
// weights below, 2x2 average pooling between scales, negative cs_j / ssim_5 clamped to 0, the
// mean over channels of the per-channel values. Throws wm::Error when a side is below
// kMsSsimMinSide.
constexpr int kMsSsimScales = 5;
constexpr double kMsSsimWeights[kMsSsimScales] = {0.0448, 0.2856, 0.3001, 0.2363, 0.1333};
constexpr int kMsSsimMinSide = kSsimMinSide << (kMsSsimScales - 1);  // 176
double MsSsim(const Image& a, const Image& b, int threads = 1);

// The metrics of one frame pair. A metric that was not asked for is NaN.
struct FrameMetrics {
  double mse = 0;
  double psnr = 0;
  double ssim = 0;
  double ms_ssim = 0;
};

// What CompareFrames computes; MSE and PSNR always.
struct MetricOptions {
  bool ssim = true;
  bool ms_ssim = true;  // needs both sides >= kMsSsimMinSide
  int threads = 0;
};

FrameMetrics CompareFrame(const Image& a, const Image& b, const MetricOptions& options);

// The metrics of a[i] vs b[i] for every i, threaded across frames. Throws wm::Error (with the
// frame index as record) when the counts or a pair's shapes differ.
std::vector<FrameMetrics> CompareFrames(const std::vector<Image>& a, const std::vector<Image>& b,
                                        const MetricOptions& options);

// Per-metric mean over frames (a video's score). PSNR is the mean of per-frame PSNR, so one
// identical frame makes it +infinity; NaN metrics stay NaN. All NaN for no frames.
FrameMetrics MeanMetrics(const std::vector<FrameMetrics>& frames);

struct VideoMetrics {
  std::vector<FrameMetrics> frames;
  FrameMetrics mean;
};
VideoMetrics CompareVideos(const std::vector<Image>& a, const std::vector<Image>& b,
                           const MetricOptions& options);

// JSON has no infinity or NaN: finite values are numbers, +inf -> "inf", -inf -> "-inf",
// NaN -> null. ToJson(FrameMetrics) gives {"mse", "psnr", "ssim", "ms_ssim"}, skipping NaN ones.
nlohmann::json JsonNumber(double value);
nlohmann::json ToJson(const FrameMetrics& metrics);

}  // namespace wm::metrics

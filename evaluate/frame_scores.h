#pragma once
// Per-step frame metrics of an imagined (or baseline) clip against the real one, on the uint8
// frames a user would see: MSE, PSNR, SSIM and MS-SSIM from the metrics library and lpips_style
// from the tokenizer's encoder (tokenize/tokenizer.h).
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "metrics/image.h"

namespace wm::tokenize {
class Tokenizer;
}
namespace wm::metrics {
class Lpips;
}

namespace wm::evaluate {

// Planar clips [frames, 3, S, S] in [-1, 1].
struct Clip {
  int64_t frames = 0;
  int size = 0;
  std::vector<float> pixels;
  const float* frame(int64_t t) const { return pixels.data() + t * 3 * size * size; }
};

// Frames [first, first + count) of `clip` as a new clip.
Clip SubClip(const Clip& clip, int64_t first, int64_t count);

// Frame `t` of `clip` as the pixel metrics score it: rounded to uint8 RGB (data range 255).
metrics::Image FrameImage(const Clip& clip, int64_t t);

// Frame `t` of `clip` repeated `count` times: the copy baselines (copy_last, copy_last_tokens).
Clip RepeatFrame(const Clip& clip, int64_t t, int64_t count);

// metric -> one value per frame pair ("mse" on [0, 255], "psnr" in dB (+inf for identical
// frames), "ssim", "ms_ssim" when frames are at least metrics::kMsSsimMinSide (176) pixels wide,
// "lpips_style", and "lpips" when `lpips` is given). `real` and `pred` have the same frame count
// and size.
std::map<std::string, std::vector<double>> ScoreFrames(const Clip& real, const Clip& pred,
                                                       const tokenize::Tokenizer& tokenizer,
                                                       metrics::Lpips* lpips = nullptr);

// Mean over pixels of the per-pixel variance across `samples` (same shape): the disagreement
// between imaginations of one step, one value per frame.
std::vector<double> SampleDisagreement(const std::vector<Clip>& samples);

}  // namespace wm::evaluate

#include "evaluate/frame_scores.h"

#include <cmath>

#include "core/error.h"
#include "metrics/image.h"
#include "metrics/lpips/lpips.h"
#include "metrics/pixel_metrics.h"
#include "tokenize/tokenizer.h"

namespace wm::evaluate {

Clip SubClip(const Clip& clip, int64_t first, int64_t count) {
  Check(first >= 0 && first + count <= clip.frames, "clip frame range out of bounds");
  const int64_t floats = 3 * int64_t{clip.size} * clip.size;
  return {count, clip.size,
          std::vector<float>(clip.pixels.begin() + first * floats,
                             clip.pixels.begin() + (first + count) * floats)};
}

Clip RepeatFrame(const Clip& clip, int64_t t, int64_t count) {
  Check(t >= 0 && t < clip.frames, "clip frame out of bounds");
  const int64_t floats = 3 * int64_t{clip.size} * clip.size;
  Clip out{count, clip.size, {}};
  out.pixels.reserve(static_cast<size_t>(count * floats));
  for (int64_t i = 0; i < count; ++i) {
    out.pixels.insert(out.pixels.end(), clip.frame(t), clip.frame(t) + floats);
  }
  return out;
}

metrics::Image FrameImage(const Clip& clip, int64_t t) {
  const std::vector<uint8_t> rgb = tokenize::PlanarToRgb8(clip.frame(t), clip.size);
  return metrics::Image::FromUint8(rgb.data(), clip.size, clip.size, 3);
}

std::map<std::string, std::vector<double>> ScoreFrames(const Clip& real, const Clip& pred,
                                                       const tokenize::Tokenizer& tokenizer,
                                                       metrics::Lpips* lpips) {
  Check(real.frames == pred.frames && real.size == pred.size, "clips differ in shape");
  std::map<std::string, std::vector<double>> out;
  const int s = real.size;
  std::vector<std::vector<uint8_t>> rgb_a, rgb_b;
  for (int64_t t = 0; t < real.frames; ++t) {
    rgb_a.push_back(tokenize::PlanarToRgb8(real.frame(t), s));
    rgb_b.push_back(tokenize::PlanarToRgb8(pred.frame(t), s));
    auto a = metrics::Image::FromUint8(rgb_a.back().data(), s, s, 3);
    auto b = metrics::Image::FromUint8(rgb_b.back().data(), s, s, 3);
    out["mse"].push_back(metrics::Mse(a, b));
    out["psnr"].push_back(metrics::Psnr(a, b));
    out["ssim"].push_back(metrics::Ssim(a, b));
    if (s >= metrics::kMsSsimMinSide) out["ms_ssim"].push_back(metrics::MsSsim(a, b));
  }
  out["lpips_style"] =
      tokenizer.PerceptualDistance(real.pixels.data(), pred.pixels.data(), real.frames);
  if (lpips != nullptr) {  // official LPIPS on the same uint8 frames as the pixel metrics
    std::vector<const uint8_t*> pa, pb;
    for (size_t t = 0; t < rgb_a.size(); ++t)
      pa.push_back(rgb_a[t].data()), pb.push_back(rgb_b[t].data());
    out["lpips"] = lpips->Distance(pa, pb, s, s);
  }
  return out;
}

std::vector<double> SampleDisagreement(const std::vector<Clip>& samples) {
  Check(samples.size() >= 2, "disagreement needs at least two samples");
  const Clip& first = samples.front();
  const size_t floats = 3ull * first.size * first.size;
  std::vector<double> out;
  for (int64_t t = 0; t < first.frames; ++t) {
    double total = 0;
    for (size_t i = 0; i < floats; ++i) {
      double mean = 0, sq = 0;
      for (const Clip& c : samples) {
        const double v = c.frame(t)[i];
        mean += v;
        sq += v * v;
      }
      mean /= samples.size();
      total += sq / samples.size() - mean * mean;
    }
    out.push_back(total / floats);
  }
  return out;
}

}  // namespace wm::evaluate

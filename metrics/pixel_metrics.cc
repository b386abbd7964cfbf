#include "metrics/pixel_metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "metrics/parallel.h"
#include "metrics/pixel_kernels.h"

namespace wm::metrics {
namespace {

using internal::GridView;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

GridView View(const Image& image) {
  return {image.height, image.width, image.channels, image.pixels.data()};
}

// Per-channel means of the SSIM map (and of the cs map when `want_cs`) without the kSsimCrop
// border: skimage's crop(S, pad).mean(). Fills `map` (HxWxC, border included) when not null.
// Rows are the work items; their sums are added in row order, whatever the thread count.
internal::SsimRowSums ChannelMeans(const GridView& a, const GridView& b, double data_range,
                                   bool want_cs, double* map, int threads) {
  const double c1 = std::pow(internal::kSsimK1 * data_range, 2);
  const double c2 = std::pow(internal::kSsimK2 * data_range, 2);
  // Without a map only the rows inside the crop are computed.
  const int y0 = map != nullptr ? 0 : kSsimCrop;
  const int rows = map != nullptr ? a.height : a.height - 2 * kSsimCrop;
  const size_t row_values = static_cast<size_t>(a.width) * a.channels;
  std::vector<internal::SsimRowSums> row_sums(rows);
  constexpr int kStep = internal::kMaxRows;
  internal::ParallelFor((rows + kStep - 1) / kStep, threads, [&](int64_t item) {
    const int first = static_cast<int>(item) * kStep, count = std::min(kStep, rows - first);
    double* map_rows[kStep] = {};
    if (map != nullptr) {
      for (int r = 0; r < count; ++r) map_rows[r] = map + (y0 + first + r) * row_values;
    }
    internal::SsimRows(a, b, y0 + first, count, c1, c2, want_cs,
                       map != nullptr ? map_rows : nullptr, &row_sums[first]);
  });

  internal::SsimRowSums means;
  const double count = double(a.height - 2 * kSsimCrop) * (a.width - 2 * kSsimCrop);
  for (int c = 0; c < a.channels; ++c) {
    for (int y = kSsimCrop; y < a.height - kSsimCrop; ++y) {
      means.ssim[c] += row_sums[y - y0].ssim[c];
      means.cs[c] += row_sums[y - y0].cs[c];
    }
    means.ssim[c] /= count;
    means.cs[c] /= count;
  }
  return means;
}

void CheckMinSide(const Image& a, int min_side, const std::string& what) {
  Check(std::min(a.height, a.width) >= min_side,
        what + " needs images of at least " + std::to_string(min_side) + "x" +
            std::to_string(min_side) + " pixels, got " + std::to_string(a.height) + "x" +
            std::to_string(a.width));
}

}  // namespace

double Mse(const Image& a, const Image& b) {
  CheckSameShape(a, b);
  return internal::SumSquaredDifference(a.pixels.data(), b.pixels.data(), a.pixels.size()) /
         static_cast<double>(a.pixels.size());
}

double PsnrFromMse(double mse, double data_range) {
  if (mse == 0) return std::numeric_limits<double>::infinity();
  return 10 * std::log10(data_range * data_range / mse);
}

double Psnr(const Image& a, const Image& b) { return PsnrFromMse(Mse(a, b), a.data_range); }

double Ssim(const Image& a, const Image& b, Image* map, int threads) {
  CheckSameShape(a, b);
  CheckMinSide(a, kSsimMinSide, "SSIM (11x11 Gaussian window)");
  if (map != nullptr) {
    map->height = a.height, map->width = a.width, map->channels = a.channels;
    map->data_range = 1.0;
    map->pixels.resize(a.size());
  }
  const auto means = ChannelMeans(View(a), View(b), a.data_range, false,
                                  map != nullptr ? map->pixels.data() : nullptr, threads);
  double sum = 0;
  for (int c = 0; c < a.channels; ++c) sum += means.ssim[c];
  return sum / a.channels;  // skimage: mean over channels of the per-channel SSIM
}

double MsSsim(const Image& a, const Image& b, int threads) {
  CheckSameShape(a, b);
  CheckMinSide(a, kMsSsimMinSide, "MS-SSIM (5 scales, 11x11 window at the smallest)");
  internal::Grid scaled_a, scaled_b;  // scales 2..5
  GridView va = View(a), vb = View(b);
  std::vector<double> product(a.channels, 1.0);
  for (int j = 0; j < kMsSsimScales; ++j) {
    const bool last = j == kMsSsimScales - 1;
    const auto means = ChannelMeans(va, vb, a.data_range, !last, nullptr, threads);
    for (int c = 0; c < a.channels; ++c) {
      // cs_j for j < 5, l_5 * cs_5 at the coarsest scale (Wang et al. 2003, eq. 7); negative
      // values (anti-correlated structure) clamp to 0 so that the fractional power is defined.
      const double term = last ? means.ssim[c] : means.cs[c];
      product[c] *= std::pow(std::max(term, 0.0), kMsSsimWeights[j]);
    }
    if (last) break;
    scaled_a = internal::Downsample2x2(va);
    scaled_b = internal::Downsample2x2(vb);
    va = scaled_a.view(), vb = scaled_b.view();
  }
  double sum = 0;
  for (double v : product) sum += v;
  return sum / a.channels;
}

FrameMetrics CompareFrame(const Image& a, const Image& b, const MetricOptions& options) {
  FrameMetrics m;
  m.mse = Mse(a, b);
  m.psnr = PsnrFromMse(m.mse, a.data_range);
  m.ssim = options.ssim ? Ssim(a, b, nullptr, options.threads) : kNaN;
  m.ms_ssim = options.ms_ssim ? MsSsim(a, b, options.threads) : kNaN;
  return m;
}

std::vector<FrameMetrics> CompareFrames(const std::vector<Image>& a, const std::vector<Image>& b,
                                        const MetricOptions& options) {
  Check(a.size() == b.size(),
        "frame counts differ: " + std::to_string(a.size()) + " vs " + std::to_string(b.size()));
  const int64_t n = static_cast<int64_t>(a.size());
  const int threads = internal::ResolveThreads(options.threads);
  // Frames are the coarsest independent items; leftover threads go inside each frame.
  MetricOptions inner = options;
  inner.threads = n >= threads ? 1 : std::max<int>(1, threads / std::max<int64_t>(n, 1));
  std::vector<FrameMetrics> out(a.size());
  internal::ParallelFor(n, threads, [&](int64_t i) {
    try {
      out[i] = CompareFrame(a[i], b[i], inner);
    } catch (const Error& e) {
      throw e.WithRecord(i, "frame");
    }
  });
  return out;
}

FrameMetrics MeanMetrics(const std::vector<FrameMetrics>& frames) {
  if (frames.empty()) return {kNaN, kNaN, kNaN, kNaN};
  FrameMetrics mean;
  for (const auto& f : frames) {
    mean.mse += f.mse, mean.psnr += f.psnr, mean.ssim += f.ssim, mean.ms_ssim += f.ms_ssim;
  }
  const double n = static_cast<double>(frames.size());
  mean.mse /= n, mean.psnr /= n, mean.ssim /= n, mean.ms_ssim /= n;
  return mean;
}

VideoMetrics CompareVideos(const std::vector<Image>& a, const std::vector<Image>& b,
                           const MetricOptions& options) {
  VideoMetrics v;
  v.frames = CompareFrames(a, b, options);
  v.mean = MeanMetrics(v.frames);
  return v;
}

nlohmann::json JsonNumber(double value) {
  if (std::isnan(value)) return nullptr;
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  return value;
}

nlohmann::json ToJson(const FrameMetrics& m) {
  nlohmann::json out = nlohmann::json::object();
  const std::pair<const char*, double> fields[] = {
      {"mse", m.mse}, {"psnr", m.psnr}, {"ssim", m.ssim}, {"ms_ssim", m.ms_ssim}};
  for (const auto& [name, value] : fields) {
    if (!std::isnan(value)) out[name] = JsonNumber(value);
  }
  return out;
}

}  // namespace wm::metrics

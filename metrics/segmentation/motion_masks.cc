// Motion masks: the robot is what moves in a fixed camera's video. OpenCV stays in this file.
// The steps and why each exists: docs/metrics-segmentation.md, "motion".
#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "metrics/segmentation/mask_source.h"

namespace wm::metrics::seg {
namespace {

using Colour = cv::Vec3f;  // RGB in units of the data range

// [H, W] RGB floats in units of the data range, so thresholds are fractions of the range
// whatever the bit depth; grey frames are repeated into the three channels.
cv::Mat ToUnitMat(const Image& image) {
  cv::Mat out(image.height, image.width, CV_32FC3);
  const double scale = 1.0 / image.data_range;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      for (int c = 0; c < 3; ++c) {
        out.at<Colour>(y, x)[c] =
            static_cast<float>(image.at(y, x, std::min(c, image.channels - 1)) * scale);
      }
    }
  }
  return out;
}

float MaxChannelDiff(const Colour& a, const Colour& b) {
  return std::max({std::abs(a[0] - b[0]), std::abs(a[1] - b[1]), std::abs(a[2] - b[2])});
}

// The distinct colours a pixel shows over the episode: leader clustering in time order with the
// change threshold, each mode's colour the per-channel median of its members.
struct Mode {
  Colour colour;
  int frames = 0;
};
std::vector<Mode> PixelModes(const std::vector<cv::Mat>& frames, int y, int x, float threshold) {
  std::vector<Colour> leaders;
  std::vector<std::vector<Colour>> members;
  for (const cv::Mat& f : frames) {
    const Colour& v = f.at<Colour>(y, x);
    size_t k = 0;
    while (k < leaders.size() && MaxChannelDiff(leaders[k], v) > threshold) ++k;
    if (k == leaders.size()) leaders.push_back(v), members.emplace_back();
    members[k].push_back(v);
  }
  std::vector<Mode> modes;
  for (std::vector<Colour>& m : members) {
    Colour median;
    for (int c = 0; c < 3; ++c) {
      std::vector<float> values;
      values.reserve(m.size());
      for (const Colour& v : m) values.push_back(v[c]);
      std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
      median[c] = values[values.size() / 2];
    }
    modes.push_back({median, static_cast<int>(m.size())});
  }
  return modes;
}

// Colour histogram (16 levels per channel) of the static scene: pixels with a single mode that
// lie at least `margin` pixels from any pixel that ever changes. The margin keeps out parts of
// the robot that never leave their place (they are single-mode too, but next to ones that move).
class SceneColours {
 public:
  SceneColours(const cv::Mat& first_frame, const cv::Mat& changing, int margin) : counts_(kBins3) {
    cv::Mat distance;
    cv::distanceTransform(255 - changing, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    // A second pass drops the margin when nothing lies that far from change (the robot fills
    // the view).
    for (int pass = 0; pass < 2 && total_ == 0; ++pass) {
      for (int y = 0; y < first_frame.rows; ++y) {
        for (int x = 0; x < first_frame.cols; ++x) {
          if (changing.at<uint8_t>(y, x) || (pass == 0 && distance.at<float>(y, x) < margin))
            continue;
          ++counts_[Bin(first_frame.at<Colour>(y, x))];
          ++total_;
        }
      }
    }
  }
  // How many static-scene pixels have about this colour (its bin and the 26 around it).
  int64_t Support(const Colour& c) const {
    int64_t sum = 0;
    const std::array<int, 3> b = Levels(c);
    for (int r = std::max(b[0] - 1, 0); r <= std::min(b[0] + 1, kBins - 1); ++r) {
      for (int g = std::max(b[1] - 1, 0); g <= std::min(b[1] + 1, kBins - 1); ++g) {
        for (int u = std::max(b[2] - 1, 0); u <= std::min(b[2] + 1, kBins - 1); ++u) {
          sum += counts_[(r * kBins + g) * kBins + u];
        }
      }
    }
    return sum;
  }

 private:
  static constexpr int kBins = 16, kBins3 = kBins * kBins * kBins;
  static std::array<int, 3> Levels(const Colour& c) {
    std::array<int, 3> b{};
    for (int k = 0; k < 3; ++k) b[k] = std::clamp(static_cast<int>(c[k] * kBins), 0, kBins - 1);
    return b;
  }
  static int Bin(const Colour& c) {
    const std::array<int, 3> b = Levels(c);
    return (b[0] * kBins + b[1]) * kBins + b[2];
  }
  std::vector<int64_t> counts_;
  int64_t total_ = 0;
};

// The scene without the robot. A temporal median fails wherever the robot stays for more than
// half of the episode (slow or short episodes); instead each pixel's background is, among the
// colours it shows in at least min_mode_frames frames, the one most common in the static scene
// (the robot's grey is rare on the table), ties going to the colour seen longest.
cv::Mat EstimateBackground(const std::vector<cv::Mat>& frames, const MotionMaskOptions& o) {
  const cv::Mat& first = frames.front();
  const float threshold = static_cast<float>(o.change_threshold);
  cv::Mat changing(first.size(), CV_8U, cv::Scalar(0));
  for (const cv::Mat& f : frames) {
    for (size_t i = 0; i < f.total(); ++i) {
      if (MaxChannelDiff(f.at<Colour>(static_cast<int>(i)), first.at<Colour>(static_cast<int>(i))) >
          threshold) {
        changing.data[i] = 255;
      }
    }
  }
  const SceneColours scene(first, changing, o.static_margin);
  cv::Mat background = first.clone();
  for (int y = 0; y < first.rows; ++y) {
    for (int x = 0; x < first.cols; ++x) {
      if (!changing.at<uint8_t>(y, x)) continue;
      const std::vector<Mode> modes = PixelModes(frames, y, x, threshold);
      const Mode* best =
          &*std::max_element(modes.begin(), modes.end(),
                             [](const Mode& a, const Mode& b) { return a.frames < b.frames; });
      int64_t best_support = scene.Support(best->colour);
      for (const Mode& m : modes) {
        const int64_t support = scene.Support(m.colour);
        if (m.frames >= o.min_mode_frames && support > best_support)
          best = &m, best_support = support;
      }
      background.at<Colour>(y, x) = best->colour;
    }
  }
  return background;
}

// Brightness ratio alpha of colour p to background b (p ~ alpha b, the projection of p on b) and
// the colour distortion ||p - alpha b|| / ||b|| (Horprasert et al. 1999).
std::pair<double, double> RatioAndDistortion(const Colour& p, const Colour& b) {
  const double bb = b.dot(b);
  if (bb < 1e-6) return {1, 1};  // black background: no shadow can be seen on it
  const double alpha = p.dot(b) / bb;
  const Colour rest = p - b * static_cast<float>(alpha);
  return {alpha, std::sqrt(rest.dot(rest) / bb)};
}

// One light casts shadows of one depth on a flat table: the ratio is the same wherever the
// robot's shadow falls, so it shows as the peak of the ratio histogram (bins of 0.02) of changed,
// undistorted, darker pixels. 0 when no such pixel exists.
double EstimateShadowRatio(const std::vector<cv::Mat>& frames, const cv::Mat& background,
                           const MotionMaskOptions& o) {
  std::array<int64_t, 50> histogram{};
  for (const cv::Mat& f : frames) {
    for (int i = 0; i < static_cast<int>(f.total()); ++i) {
      const Colour& p = f.at<Colour>(i);
      const Colour& b = background.at<Colour>(i);
      if (MaxChannelDiff(p, b) <= o.change_threshold) continue;
      const auto [alpha, distortion] = RatioAndDistortion(p, b);
      if (distortion <= o.shadow_max_distortion && alpha > 0 && alpha < 1) {
        ++histogram[static_cast<size_t>(alpha * 50)];
      }
    }
  }
  const auto peak = std::max_element(histogram.begin(), histogram.end());
  return *peak == 0 ? 0.0 : (static_cast<double>(peak - histogram.begin()) + 0.5) / 50;
}

// 255 where the frame differs from the background by more than the threshold and the
// difference is not the background in shadow.
cv::Mat ChangedPixels(const cv::Mat& frame, const cv::Mat& background, double shadow_ratio,
                      const MotionMaskOptions& o) {
  cv::Mat changed(frame.size(), CV_8U, cv::Scalar(0));
  for (int i = 0; i < static_cast<int>(frame.total()); ++i) {
    const Colour& p = frame.at<Colour>(i);
    const Colour& b = background.at<Colour>(i);
    if (MaxChannelDiff(p, b) <= o.change_threshold) continue;
    if (shadow_ratio > 0) {
      const auto [alpha, distortion] = RatioAndDistortion(p, b);
      if (std::abs(alpha - shadow_ratio) <= o.shadow_ratio_tolerance &&
          distortion <= o.shadow_max_distortion) {
        continue;
      }
    }
    changed.data[i] = 255;
  }
  return changed;
}

cv::Mat Disc(int radius) {
  return cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * radius + 1, 2 * radius + 1});
}

// Opening drops isolated speckle (JPEG ringing at strong edges); closing joins parts of the
// arm split where its colour happens to match the table.
cv::Mat CleanUp(const cv::Mat& changed, const MotionMaskOptions& o) {
  cv::Mat mask = changed;
  if (o.open_radius > 0) cv::morphologyEx(mask, mask, cv::MORPH_OPEN, Disc(o.open_radius));
  if (o.close_radius > 0) cv::morphologyEx(mask, mask, cv::MORPH_CLOSE, Disc(o.close_radius));
  return mask;
}

// Connected parts of the changed mask: those touching an arm border are the arm. When none does
// (the link hidden, e.g. a grey link on a grey table), the largest part is: the robot is what
// moves most. Other large parts (a pushed object, the place it left, a passing shadow) are in no
// region, since motion alone cannot tell what they are; small ones and unchanged pixels are
// background.
RegionMap LabelParts(const cv::Mat& mask, const MotionMaskOptions& o) {
  cv::Mat labels, stats, centroids;
  const int parts = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  std::vector<bool> touches(parts, false);
  for (int y = 0; y < mask.rows; ++y) {
    for (int x = 0; x < mask.cols; ++x) {
      if (o.arm_borders.Touches(y, x, mask.rows, mask.cols)) touches[labels.at<int>(y, x)] = true;
    }
  }
  auto area = [&](int k) { return stats.at<int>(k, cv::CC_STAT_AREA); };
  const double min_pixels = o.min_part_fraction * static_cast<double>(mask.total());
  std::vector<Region> part_region(parts, Region::kBackground);
  int largest = 0;  // 0 is the unchanged pixels
  bool arm_found = false;
  for (int k = 1; k < parts; ++k) {
    if (area(k) < min_pixels) continue;
    part_region[k] = touches[k] ? Region::kArm : Region::kNone;
    arm_found = arm_found || touches[k];
    if (largest == 0 || area(k) > area(largest)) largest = k;
  }
  if (!arm_found && largest > 0) part_region[largest] = Region::kArm;
  RegionMap map(mask.rows, mask.cols);
  for (int y = 0; y < mask.rows; ++y) {
    for (int x = 0; x < mask.cols; ++x) map.at(y, x) = part_region[labels.at<int>(y, x)];
  }
  return map;
}

class MotionMaskSource : public MaskSource {
 public:
  explicit MotionMaskSource(const MotionMaskOptions& options) : options_(options) {
    options_.Check();
  }
  std::string name() const override { return "motion"; }

  std::vector<RegionMap> Masks(const Frames& reference) const override {
    const std::string where = reference.sources.empty() ? "" : reference.sources.front();
    // With fewer frames no colour can outvote the robot's.
    Check(reference.images.size() >= 3,
          "motion masks need at least 3 reference frames, got " +
              std::to_string(reference.images.size()),
          {.file = where});
    std::vector<cv::Mat> frames;
    for (size_t t = 0; t < reference.images.size(); ++t) {
      try {
        CheckSameShape(reference.images.front(), reference.images[t]);
      } catch (const Error& e) {
        throw e.WithFile(reference.sources[t]);
      }
      frames.push_back(ToUnitMat(reference.images[t]));
    }
    const cv::Mat background = EstimateBackground(frames, options_);
    const double shadow_ratio = !options_.shadows ? 0
                                : options_.shadow_ratio > 0
                                    ? options_.shadow_ratio
                                    : EstimateShadowRatio(frames, background, options_);
    std::vector<RegionMap> maps;
    maps.reserve(frames.size());
    for (const cv::Mat& frame : frames) {
      maps.push_back(LabelParts(
          CleanUp(ChangedPixels(frame, background, shadow_ratio, options_), options_), options_));
    }
    return maps;
  }

 private:
  MotionMaskOptions options_;
};

}  // namespace

std::unique_ptr<MaskSource> MakeMotionMaskSource(const MotionMaskOptions& options) {
  return std::make_unique<MotionMaskSource>(options);
}

}  // namespace wm::metrics::seg

// The mask-source options, their checks, and the label-file source (the other two sources live
// in motion_masks.cc and depth_masks.cc with their heavy dependencies).
#include "metrics/segmentation/mask_source.h"

#include <cmath>
#include <sstream>

#include "core/error.h"

namespace wm::metrics::seg {
namespace {

std::vector<std::string> SplitComma(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream in(text);
  for (std::string part; std::getline(in, part, ',');) {
    const size_t a = part.find_first_not_of(" \t"), b = part.find_last_not_of(" \t");
    parts.push_back(a == std::string::npos ? "" : part.substr(a, b - a + 1));
  }
  return parts;
}

void CheckRange(double value, double lo, double hi, const std::string& field) {
  Check(std::isfinite(value) && value >= lo && value <= hi,
        "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
            std::to_string(value),
        {.key = field});
}

class FileMaskSource : public MaskSource {
 public:
  FileMaskSource(Frames labels, LabelMap map) : labels_(std::move(labels)), map_(std::move(map)) {
    map_.Check();
  }
  std::string name() const override { return "files"; }

  std::vector<RegionMap> Masks(const Frames& reference) const override {
    CheckAlongside(labels_, "label image", reference);
    std::vector<RegionMap> maps;
    for (size_t t = 0; t < labels_.images.size(); ++t) {
      const Image& label = labels_.images[t];
      RegionMap map(label.height, label.width);
      for (size_t i = 0; i < label.pixels.size(); ++i) {
        const double value = label.pixels[i];
        try {
          Check(value == std::floor(value),
                "label " + std::to_string(value) + " is not an integer");
          map.pixels[i] = map_.Lookup(static_cast<int>(value));
        } catch (const Error& e) {
          const std::string where = "pixel (x " + std::to_string(i % label.width) + ", y " +
                                    std::to_string(i / label.width) + "): ";
          throw Error(where + e.message(), {.file = labels_.sources[t]});
        }
      }
      maps.push_back(std::move(map));
    }
    return maps;
  }

 private:
  Frames labels_;
  LabelMap map_;
};

}  // namespace

Region LabelMap::Lookup(int label) const {
  const auto it = regions.find(label);
  if (it != regions.end()) return it->second;
  wm::Check(unlisted.has_value(), "label " + std::to_string(label) +
                                      " is not in the label map (list it, or set 'unlisted')");
  return *unlisted;
}

void LabelMap::Check() const {
  wm::Check(!regions.empty(), "the label map is empty: list label -> region pairs",
            {.key = "labels"});
}

ArmBorders ArmBorders::Parse(const std::string& list) {
  ArmBorders b{false, false, false, false};
  for (const std::string& word : SplitComma(list)) {
    bool* flag = word == "top"      ? &b.top
                 : word == "bottom" ? &b.bottom
                 : word == "left"   ? &b.left
                 : word == "right"  ? &b.right
                                    : nullptr;
    wm::Check(flag != nullptr, "unknown border '" + word + "': expected top, bottom, left, right",
              {.key = "arm_borders"});
    *flag = true;
  }
  wm::Check(b.top || b.bottom || b.left || b.right, "name at least one border",
            {.key = "arm_borders"});
  return b;
}

std::string ArmBorders::ToString() const {
  std::string out;
  for (auto [on, word] :
       {std::pair{top, "top"}, {bottom, "bottom"}, {left, "left"}, {right, "right"}}) {
    if (on) out += (out.empty() ? "" : ",") + std::string(word);
  }
  return out;
}

bool ArmBorders::Touches(int y, int x, int height, int width) const {
  return (top && y == 0) || (bottom && y == height - 1) || (left && x == 0) ||
         (right && x == width - 1);
}

void MotionMaskOptions::Check() const {
  CheckRange(change_threshold, 1e-6, 1, "motion.change_threshold");
  CheckRange(min_mode_frames, 1, 1e6, "motion.min_mode_frames");
  CheckRange(static_margin, 0, 1e4, "motion.static_margin");
  CheckRange(shadow_ratio, 0, 1, "motion.shadow_ratio");
  CheckRange(shadow_ratio_tolerance, 0, 1, "motion.shadow_ratio_tolerance");
  CheckRange(shadow_max_distortion, 0, 1, "motion.shadow_max_distortion");
  CheckRange(open_radius, 0, 50, "motion.open_radius");
  CheckRange(close_radius, 0, 50, "motion.close_radius");
  CheckRange(min_part_fraction, 0, 1, "motion.min_part_fraction");
}

CameraIntrinsics CameraIntrinsics::Parse(const std::string& text) {
  const std::vector<std::string> parts = SplitComma(text);
  const std::string expected = "expected fx,fy,cx,cy in pixels (four numbers), got '" + text + "'";
  wm::Check(parts.size() == 4, expected, {.key = "--intrinsics"});
  double v[4];
  for (int i = 0; i < 4; ++i) {
    size_t used = 0;
    try {
      v[i] = std::stod(parts[i], &used);
    } catch (const std::exception&) {
      used = 0;
    }
    wm::Check(used > 0 && used == parts[i].size() && std::isfinite(v[i]), expected,
              {.key = "--intrinsics"});
  }
  wm::Check(v[0] > 0 && v[1] > 0, "focal lengths fx, fy must be positive, got '" + text + "'",
            {.key = "--intrinsics"});
  return {v[0], v[1], v[2], v[3]};
}

void DepthMaskOptions::Check() const {
  wm::Check(intrinsics.has_value(),
            "depth masks need the camera intrinsics: pass --intrinsics fx,fy,cx,cy (tabletop "
            "episodes carry them as episode_metadata/camera_intrinsics)",
            {.key = "--intrinsics"});
  CheckRange(depth_scale, 1e-9, 1e3, "depth.depth_scale");
  CheckRange(plane_distance, 1e-6, 10, "depth.plane_distance");
  CheckRange(plane_iterations, 1, 1e6, "depth.plane_iterations");
  CheckRange(cluster_tolerance, 1e-6, 10, "depth.cluster_tolerance");
  CheckRange(min_cluster_points, 1, 1e9, "depth.min_cluster_points");
}

void CheckAlongside(const Frames& what, const std::string& kind, const Frames& reference) {
  const std::string where = what.sources.empty() ? "" : what.sources.front();
  Check(what.images.size() == reference.images.size(),
        "expected one " + kind + " per reference frame (" +
            std::to_string(reference.images.size()) + "), found " +
            std::to_string(what.images.size()),
        {.file = where});
  for (size_t t = 0; t < what.images.size(); ++t) {
    const Image& image = what.images[t];
    const Image& ref = reference.images[t];
    Check(image.channels == 1, "expected a single-channel " + kind + ", got " + ShapeString(image),
          {.file = what.sources[t]});
    Check(image.height == ref.height && image.width == ref.width,
          "expected a " + kind + " of the reference frame's size " + std::to_string(ref.height) +
              "x" + std::to_string(ref.width) + " (" + reference.sources[t] + "), got " +
              ShapeString(image),
          {.file = what.sources[t]});
  }
}

std::unique_ptr<MaskSource> MakeFileMaskSource(Frames labels, LabelMap map) {
  return std::make_unique<FileMaskSource>(std::move(labels), std::move(map));
}

}  // namespace wm::metrics::seg

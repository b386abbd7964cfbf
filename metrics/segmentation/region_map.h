#pragma once
// Region maps: which scene region (robot arm, manipulated object, background) each pixel of a
// frame shows. Segmented-region MSE (segmented_mse.h) and every mask source (mask_source.h)
// speak this type; docs/metrics-segmentation.md defines the regions.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace wm::metrics::seg {

// Pixel values of a RegionMap (and of the PNGs `wm-metrics seg --save-masks` writes).
enum class Region : uint8_t {
  kBackground = 0,  // static scene: table, walls, goal markings
  kArm = 1,         // robot arm and gripper
  kObject = 2,      // objects the robot manipulates
  kNone = 255,      // in no region: unmapped label, invalid depth, unexplained motion
};

// The regions a metric is reported for, in output order.
inline constexpr Region kRegions[] = {Region::kArm, Region::kObject, Region::kBackground};

// "arm", "object", "background", "none".
std::string RegionName(Region region);
// Inverse of RegionName (also accepts "none"); throws wm::Error naming the valid names.
Region ParseRegion(const std::string& name);

// One frame's regions, row-major height x width.
struct RegionMap {
  int height = 0;
  int width = 0;
  std::vector<Region> pixels;

  RegionMap() = default;
  RegionMap(int h, int w, Region fill = Region::kNone)
      : height(h), width(w), pixels(static_cast<size_t>(h) * w, fill) {}
  Region& at(int y, int x) { return pixels[static_cast<size_t>(y) * width + x]; }
  Region at(int y, int x) const { return pixels[static_cast<size_t>(y) * width + x]; }
  // Pixels of `region`.
  int64_t Count(Region region) const;
};

// Intersection over union of `region` between predicted and true maps, pooled over all frames
// (sum of intersections / sum of unions). Empty when the region is in neither. Throws
// wm::Error (frame as record) when counts or sizes differ.
std::optional<double> RegionIoU(const std::vector<RegionMap>& predicted,
                                const std::vector<RegionMap>& truth, Region region);

// Writes `map` atomically as an 8-bit single-channel PNG of its Region values (0 background,
// 1 arm, 2 object, 255 none); throws wm::Error naming the file.
void WriteRegionMapPng(const std::string& path, const RegionMap& map);

}  // namespace wm::metrics::seg

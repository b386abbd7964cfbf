#include "metrics/segmentation/region_map.h"

#include <algorithm>

#include "core/error.h"

namespace wm::metrics::seg {

std::string RegionName(Region region) {
  switch (region) {
    case Region::kBackground:
      return "background";
    case Region::kArm:
      return "arm";
    case Region::kObject:
      return "object";
    case Region::kNone:
      break;
  }
  return "none";
}

Region ParseRegion(const std::string& name) {
  for (Region r : {Region::kArm, Region::kObject, Region::kBackground, Region::kNone}) {
    if (RegionName(r) == name) return r;
  }
  throw Error("unknown region '" + name + "': expected arm, object, background or none");
}

int64_t RegionMap::Count(Region region) const {
  return std::count(pixels.begin(), pixels.end(), region);
}

std::optional<double> RegionIoU(const std::vector<RegionMap>& predicted,
                                const std::vector<RegionMap>& truth, Region region) {
  Check(predicted.size() == truth.size(),
        "IoU needs as many predicted maps (" + std::to_string(predicted.size()) +
            ") as true maps (" + std::to_string(truth.size()) + ")");
  int64_t intersection = 0, uni = 0;
  for (size_t t = 0; t < truth.size(); ++t) {
    const RegionMap& p = predicted[t];
    const RegionMap& g = truth[t];
    Check(p.height == g.height && p.width == g.width,
          "predicted and true region maps differ in size",
          {.record = static_cast<int64_t>(t), .record_label = "frame"});
    for (size_t i = 0; i < g.pixels.size(); ++i) {
      const bool in_p = p.pixels[i] == region, in_g = g.pixels[i] == region;
      intersection += in_p && in_g;
      uni += in_p || in_g;
    }
  }
  if (uni == 0) return std::nullopt;
  return static_cast<double>(intersection) / static_cast<double>(uni);
}

}  // namespace wm::metrics::seg

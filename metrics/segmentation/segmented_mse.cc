#include "metrics/segmentation/segmented_mse.h"

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "metrics/pixel_metrics.h"

namespace wm::metrics::seg {
namespace {

nlohmann::json OptionalNumber(const std::optional<double>& value) {
  return value ? JsonNumber(*value) : nlohmann::json(nullptr);
}

}  // namespace

size_t RegionSlot(Region region) {
  for (size_t k = 0; k < kNumRegions; ++k) {
    if (kRegions[k] == region) return k;
  }
  throw Error("region '" + RegionName(region) + "' has no metric slot");
}

FrameSegmentedMse FrameMse(const Image& reference, const Image& prediction, const RegionMap& map) {
  CheckSameShape(reference, prediction);
  Check(map.height == reference.height && map.width == reference.width,
        "region map is " + std::to_string(map.height) + "x" + std::to_string(map.width) +
            " but the frames are " + ShapeString(reference));
  // Sums per region in pixel order, so the result is the same on every run and machine.
  std::array<double, kNumRegions> sums{};
  std::array<int64_t, kNumRegions> counts{};
  double total = 0;
  const int c = reference.channels;
  for (size_t i = 0; i < map.pixels.size(); ++i) {
    double pixel = 0;
    for (int k = 0; k < c; ++k) {
      const double d = reference.pixels[i * c + k] - prediction.pixels[i * c + k];
      pixel += d * d;
    }
    total += pixel;
    if (map.pixels[i] == Region::kNone) continue;
    const size_t slot = RegionSlot(map.pixels[i]);
    sums[slot] += pixel;
    ++counts[slot];
  }
  FrameSegmentedMse out;
  out.mse = total / static_cast<double>(reference.size());
  for (size_t k = 0; k < kNumRegions; ++k) {
    out.regions[k].pixels = counts[k];
    if (counts[k] > 0) out.regions[k].mse = sums[k] / static_cast<double>(counts[k] * c);
  }
  return out;
}

SegmentedMse VideoMse(const std::vector<Image>& reference, const std::vector<Image>& prediction,
                      const std::vector<RegionMap>& maps) {
  Check(!reference.empty(), "no frames to compare");
  Check(reference.size() == prediction.size() && reference.size() == maps.size(),
        "frame counts differ: " + std::to_string(reference.size()) + " reference, " +
            std::to_string(prediction.size()) + " predicted, " + std::to_string(maps.size()) +
            " region maps");
  SegmentedMse out;
  out.data_range = reference.front().data_range;
  std::array<double, kNumRegions> sums{};
  double total = 0;
  for (size_t t = 0; t < reference.size(); ++t) {
    try {
      out.frames.push_back(FrameMse(reference[t], prediction[t], maps[t]));
    } catch (const Error& e) {
      throw e.WithRecord(static_cast<int64_t>(t), "frame");
    }
    const FrameSegmentedMse& f = out.frames.back();
    total += f.mse;
    for (size_t k = 0; k < kNumRegions; ++k) {
      if (!f.regions[k].mse) continue;
      sums[k] += *f.regions[k].mse;
      ++out.region_frames[k];
    }
  }
  out.mse = total / static_cast<double>(reference.size());
  for (size_t k = 0; k < kNumRegions; ++k) {
    if (out.region_frames[k] > 0) {
      out.region_mse[k] = sums[k] / static_cast<double>(out.region_frames[k]);
    }
  }
  return out;
}

nlohmann::json ToJson(const SegmentedMse& result, const std::vector<std::string>* sources) {
  nlohmann::json out = {{"frames", result.frames.size()},
                        {"data_range", JsonNumber(result.data_range)},
                        {"mse", JsonNumber(result.mse)}};
  for (size_t k = 0; k < kNumRegions; ++k) {
    const std::string name = RegionName(kRegions[k]);
    out["mse_" + name] = OptionalNumber(result.region_mse[k]);
    out["frames_" + name] = result.region_frames[k];
  }
  if (sources == nullptr) return out;
  Check(sources->size() == result.frames.size(), "one source name per frame expected");
  nlohmann::json rows = nlohmann::json::array();
  for (size_t t = 0; t < result.frames.size(); ++t) {
    const FrameSegmentedMse& f = result.frames[t];
    nlohmann::json row = {{"frame", (*sources)[t]}, {"mse", JsonNumber(f.mse)}};
    for (size_t k = 0; k < kNumRegions; ++k) {
      const std::string name = RegionName(kRegions[k]);
      row["mse_" + name] = OptionalNumber(f.regions[k].mse);
      row["pixels_" + name] = f.regions[k].pixels;
    }
    rows.push_back(std::move(row));
  }
  out["per_frame"] = std::move(rows);
  return out;
}

}  // namespace wm::metrics::seg

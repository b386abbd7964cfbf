#pragma once
// Segmented-region MSE (Quevedo, Liang, Yang, "Evaluating Robot Policies in a World Model",
// eq. 3, MSE^arm / MSE^obj): the MSE between a reference and a predicted frame restricted to
// the pixels of one region (arm, object, background) of the reference frame's region map, then
// the mean over frames (per-frame MSE first, as eq. 3; not pooled over all pixels):
//
//   MSE^r = 1/|T_r| sum_{t in T_r} 1/(|M_t^r| C) sum_{(i,j) in M_t^r} sum_c (o_t - ô_t)^2
//
// T_r = the frames whose mask M_t^r is not empty (eq. 3's 1/|M_t| is undefined on the others).
// A region empty in every frame is missing (std::nullopt, JSON null), never 0. Units: squared
// data units, like metrics::Mse; divide by data_range^2 for the paper's [0, 1] scale.
#include <array>
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <vector>

#include "metrics/image.h"
#include "metrics/segmentation/region_map.h"

namespace wm::metrics::seg {

inline constexpr size_t kNumRegions = std::size(kRegions);
// Position of `region` in kRegions (arm 0, object 1, background 2); kNone has none.
size_t RegionSlot(Region region);

// One region of one frame.
struct RegionMse {
  std::optional<double> mse;  // empty when the region has no pixel in this frame
  int64_t pixels = 0;         // |M_t^r|
};

struct FrameSegmentedMse {
  double mse = 0;                                // whole frame, equals metrics::Mse
  std::array<RegionMse, kNumRegions> regions{};  // by RegionSlot
};

struct SegmentedMse {
  std::vector<FrameSegmentedMse> frames;
  double data_range = 0;  // R of the frames (255 for 8-bit), to rescale to [0, 1] units
  double mse = 0;         // mean over frames of the whole-frame MSE
  // Per region (by RegionSlot): the mean over the frames where the region is present, and how
  // many frames that is.
  std::array<std::optional<double>, kNumRegions> region_mse{};
  std::array<int64_t, kNumRegions> region_frames{};
};

// Throws wm::Error when shapes or data ranges differ or the map is not the frames' size.
FrameSegmentedMse FrameMse(const Image& reference, const Image& prediction, const RegionMap& map);

// One map per frame, from the reference video. Throws wm::Error (frame as record) on a count or
// shape mismatch.
SegmentedMse VideoMse(const std::vector<Image>& reference, const std::vector<Image>& prediction,
                      const std::vector<RegionMap>& maps);

// {"frames", "data_range", "mse", "mse_arm", "mse_object", "mse_background", "frames_arm", ...};
// missing regions are null. With `sources` (one per frame) a "per_frame" array is added, each entry
// {"frame": source, "mse", "mse_<region>", "pixels_<region>"}. The layout is
// schemas/segmented-mse.schema.json.
nlohmann::json ToJson(const SegmentedMse& result, const std::vector<std::string>* sources);

}  // namespace wm::metrics::seg

#pragma once
// Segmented-region MSE in wm-eval (--masks): region maps (arm, object, background) of each
// held-out episode's real frames from one of the metrics library's mask sources, computed at the
// shard's resolution over the whole episode (the motion source needs every frame) and resized
// with nearest neighbour to the tokenizer's frame size, where the rollouts are scored.
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/episode.h"
#include "evaluate/frame_scores.h"
#include "metrics/segmentation/seg_config.h"

namespace wm::evaluate {

struct MaskOptions {
  std::string source = "none";  // none, files, motion or depth
  std::string seg_config;       // configs/segmentation/*.yaml: labels, motion and depth options
  std::string labels_key = "segmentation";  // the shard image stream of the files source
  std::string depth_key = "depth";          // the shard image stream of the depth source
  std::string intrinsics;                   // "fx,fy,cx,cy" at the shard's resolution (depth)
};

class RegionMasks {
 public:
  // Throws wm::Error naming the config or option that is missing or wrong.
  explicit RegionMasks(const MaskOptions& options);
  bool enabled() const { return options_.source != "none"; }
  // Maps of the episode's steps [first, first + count) at size x size. `where` names the episode
  // in errors. Throws wm::Error when the episode lacks the stream the source reads.
  std::vector<metrics::seg::RegionMap> Maps(const Episode& episode, const std::string& image_key,
                                            int64_t first, int64_t count, int size,
                                            const std::string& where) const;

 private:
  MaskOptions options_;
  metrics::seg::SegConfig config_;
};

// Per step, "mse_arm", "mse_object", "mse_background" of `pred` against `real` on [0, 255]
// (WPE eq. 3 per frame); NaN where the region has no pixel in that frame, so the episode means
// skip it rather than count it as 0.
std::map<std::string, std::vector<double>> ScoreRegions(
    const Clip& real, const Clip& pred, const std::vector<metrics::seg::RegionMap>& maps);

}  // namespace wm::evaluate

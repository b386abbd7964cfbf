#include "ingest/validate.h"

#include <cmath>

#include "core/error.h"
#include "ingest/image_codec.h"

namespace wm::ingest {
namespace {

void CheckFinite(const std::vector<float>& v, int width, const std::string& key) {
  for (size_t i = 0; i < v.size(); ++i) {
    if (!std::isfinite(v[i])) {
      throw Error("non-finite value " + std::to_string(v[i]) + " at step " +
                      std::to_string(i / width) + ", dimension " + std::to_string(i % width),
                  {.key = key});
    }
  }
}

void CheckLength(size_t size, int64_t t, int width, const std::string& key) {
  Check(size == static_cast<size_t>(t * width),
        "has " + std::to_string(size) + " values, expected " + std::to_string(t * width),
        {.key = key});
}

}  // namespace

void ValidateEpisode(Episode& e, bool full_image_check) {
  const int64_t t = e.num_steps;
  Check(t > 0, "episode has no steps");
  Check(e.action_dim >= 1 && e.action_dim <= kMaxActionDim,
        "action width " + std::to_string(e.action_dim) + " is out of range", {.key = "action"});
  const int width = static_cast<int>(e.action_dim);
  CheckLength(e.actions.size(), t, width, "action");
  CheckLength(e.rewards.size(), t, 1, "reward");
  CheckLength(e.discounts.size(), t, 1, "discount");
  CheckLength(e.is_first.size(), t, 1, "is_first");
  CheckLength(e.is_last.size(), t, 1, "is_last");
  CheckLength(e.is_terminal.size(), t, 1, "is_terminal");
  CheckFinite(e.actions, width, "action");
  CheckFinite(e.rewards, 1, "reward");
  CheckFinite(e.discounts, 1, "discount");
  Check(e.images.count("image") == 1, "episode has no camera image stream");
  for (auto& [name, frames] : e.images) {
    CheckLength(frames.frames.size(), t, 1, name);
    try {
      CheckFrames(frames, full_image_check);
    } catch (const Error& err) {
      throw err.WithKey(name);
    }
  }
}

}  // namespace wm::ingest

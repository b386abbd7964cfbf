#pragma once
// Side-by-side MP4 strips for looking at rollouts: real | each rollout | |real - first rollout|
// as a heat map, one row of panels per step.
#include <cstdint>
#include <map>
#include <string>

#include "evaluate/frame_scores.h"

namespace wm::evaluate {

// Writes DIR/episode_K.mp4 (H.264, 4 fps; docs/videos.md). `rollouts`: name -> clip with real's
// frame count.
void WriteClipVideo(const std::string& dir, int64_t episode, const Clip& real,
                    const std::map<std::string, Clip>& rollouts);

}  // namespace wm::evaluate

#pragma once
// A shard dataset whose motion is a known function of the action: a red square moves by
// 3 pixels per unit of (dx, dy), clamped to the frame, over a brown background with a static
// blue disc that must stay where it is. Small enough that the motion model learns it in seconds.
#include <string>

#include "motion/config.h"

namespace wm::motion::test {

// `episodes` episodes of `steps` steps of 32x32 PNG frames; actions (7 values, eef_delta): dx,
// dy in {-1, 1} drawn from `seed` (turned back at the borders), the rest 0: every step moves
// the square. index.json "dataset" = `name`.
// `textured`: the background is a checkerboard of 4-pixel cells (as the tabletop's varied look)
// instead of flat brown.
void WriteMovingSquares(const std::string& dir, int episodes, int steps, uint64_t seed,
                        const std::string& name = "moving_square", bool textured = false);

// 32x32 frames, 16 channels, batch 8: trains in seconds on one core.
MotionConfig TestConfig();

}  // namespace wm::motion::test

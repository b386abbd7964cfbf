#pragma once
// Which frames and actions form the model's context at each rollout step: the plain sliding
// window, and WHALE's retracing rollout (whale-x.txt section 3.4, eq. 6). Pure functions of the
// logged actions, so they are unit-tested on hand-written sequences.
//
// Indexing (0-based): frame 0 is the real first observation; actions[i] ([T, 7] row-major)
// leads from frame i to frame i+1; predicting frame t+1 uses frames up to t.
#include <array>
#include <cstdint>
#include <vector>

#include "core/episode.h"

namespace wm::evaluate {

using Action = std::array<float, kActionDim>;

// WHALE eq. 6: retrace(a_1..a_n) = (sum of dims 0-5 over the n actions, dim 6 of the last):
// end-effector deltas add up; the gripper command is the latest one. `n` >= 1.
Action RetraceAction(const float* actions, int64_t n);

struct ContextSlot {
  int64_t frame = 0;  // which frame of the rollout fills this slot (0 = the real first frame)
  Action action{};    // the action taken from it
};

// The last min(C, t+1) frames t-C+1..t with their logged actions.
std::vector<ContextSlot> PlainContext(const float* actions, int64_t t, int64_t context);

// Once the plain window has slid past frame 0 (t >= C), the first slot is frame 0 with the
// retrace of the skipped actions a_0..a_{t-C+1} (so it leads to frame t-C+2, the next slot),
// followed by frames t-C+2..t; before that it equals PlainContext.
std::vector<ContextSlot> RetraceContext(const float* actions, int64_t t, int64_t context);

}  // namespace wm::evaluate

#pragma once
// Which frames and actions form the model's context at each rollout step: the plain sliding
// window, and WHALE's retracing rollout (whale-x.txt section 3.4, eq. 6). Pure functions of the
// logged actions, so they are unit-tested on hand-written sequences.
//
// Indexing (0-based): frame 0 is the real first observation; actions[i] ([T, dim] row-major)
// leads from frame i to frame i+1; predicting frame t+1 uses frames up to t. Retracing is only
// meaningful for end-effector deltas (eef_delta); CheckRolloutModeFits (rollout.h) refuses
// other action spaces.
#include <cstdint>
#include <vector>

namespace wm::evaluate {

using Action = std::vector<float>;  // one action: `dim` values

// WHALE eq. 6: retrace(a_1..a_n) = (sum of dims 0..dim-2 over the n actions, the last dim of the
// last action): end-effector deltas add up; the gripper command is the latest one (for the
// canonical 7-dim action: dims 0-5 summed, dim 6 of the last). `n` >= 1, `dim` >= 1.
Action RetraceAction(const float* actions, int64_t dim, int64_t n);

struct ContextSlot {
  int64_t frame = 0;  // which frame of the rollout fills this slot (0 = the real first frame)
  Action action{};    // the action taken from it
};

// The last min(C, t+1) frames t-C+1..t with their logged actions.
std::vector<ContextSlot> PlainContext(const float* actions, int64_t dim, int64_t t,
                                      int64_t context);

// Once the plain window has slid past frame 0 (t >= C), the first slot is frame 0 with the
// retrace of the skipped actions a_0..a_{t-C+1} (so it leads to frame t-C+2, the next slot),
// followed by frames t-C+2..t; before that it equals PlainContext. It is AnchoredContext with
// C-1 kept frames once t >= C.
std::vector<ContextSlot> RetraceContext(const float* actions, int64_t dim, int64_t t,
                                        int64_t context);

// The real frame 0 as anchor followed by the newest `kept` (>= 0) frames t-kept+1..t; the
// anchor's action is the retrace of a_0..a_{t-kept}, the t-kept+1 steps folded back to frame 0
// (so it leads to frame t-kept+1, or with kept = 0 straight to the predicted frame t+1). When
// kept >= t nothing is left to fold: frames 0..t with their own actions. Context frames:
// min(kept, t) + 1. Different `kept` give the retracing variants of one step whose disagreement
// is wm-eval --retrace-ks' uncertainty (WHALE section 3.4).
std::vector<ContextSlot> AnchoredContext(const float* actions, int64_t dim, int64_t t,
                                         int64_t kept);

}  // namespace wm::evaluate

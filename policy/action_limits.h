#pragma once
// The tabletop world's per-step action limits, applied to every action a policy answers before it
// acts: by the simulator (ingest/tabletop/scene.h, StepScene) and by wm-eval --policy before the
// action enters the world model's context, so both see the same actions (docs/sim-policy.md).
#include <algorithm>

namespace wm::policy {

// |dx|, |dy|, |dz| <= 4 cm and |droll|, |dpitch|, |dyaw| <= 0.25 rad per step; gripper in [0, 1].
inline constexpr double kTabletopMaxTranslationStep = 0.04;
inline constexpr double kTabletopMaxRotationStep = 0.25;

// Clamps the 7 values at `action` ([dx, dy, dz, droll, dpitch, dyaw, gripper]) in place.
inline void ClampTabletopAction(float* action) {
  for (int i = 0; i < 3; ++i) {
    action[i] = static_cast<float>(
        std::clamp<double>(action[i], -kTabletopMaxTranslationStep, kTabletopMaxTranslationStep));
    action[i + 3] = static_cast<float>(
        std::clamp<double>(action[i + 3], -kTabletopMaxRotationStep, kTabletopMaxRotationStep));
  }
  action[6] = static_cast<float>(std::clamp<double>(action[6], 0, 1));
}

}  // namespace wm::policy

#pragma once
// The seed a policy is reset with, derived from the episode's own seed (the dataset's
// episode_metadata/episode_seed). wm-sim-policy and wm-eval --policy derive it the same way, so a
// policy that samples (action noise, a random walk) draws the same numbers from the same start
// in the simulator and in the world model, and the two values are paired per start.
#include <cstdint>

#include "core/mix_bits.h"

namespace wm::policy {

// Mixed with a constant ("policy" in ASCII) so that the policy's draws are not the ones that laid
// out the scene; 63 bits, so it fits a JSON integer of any reader.
inline uint64_t PolicySeed(uint64_t episode_seed) {
  return MixBits(episode_seed ^ 0x706f6c696379ULL) >> 1;
}

// Rollout `rollout` (0, 1, ...) of one start: rollout 0 gets PolicySeed (the simulator's), later
// ones independent seeds.
inline uint64_t RolloutPolicySeed(uint64_t episode_seed, int rollout) {
  const uint64_t first = PolicySeed(episode_seed);
  return rollout == 0 ? first : MixBits(first ^ static_cast<uint64_t>(rollout)) >> 1;
}

}  // namespace wm::policy

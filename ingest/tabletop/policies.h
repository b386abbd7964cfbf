#pragma once
// Scripted policies of clearly different skill, so that values estimated from the data differ:
//   expert      approach the block, grasp it, carry it to the goal (succeeds almost always)
//   noisy       expert + Gaussian action noise (slower; sometimes drops the block)
//   random      random walk of the end effector, random gripper (rarely succeeds)
//   wrong_goal  expert skill, but carries the block away from the goal and puts it down there
#include <memory>
#include <string>
#include <vector>

#include "ingest/tabletop/rng.h"
#include "ingest/tabletop/scene.h"

namespace wm::tabletop {

enum class PolicyKind { kExpert, kNoisy, kRandom, kWrongGoal };

// "expert", "noisy", "random", "wrong_goal" (the policy_id written to the dataset).
std::string PolicyName(PolicyKind kind);
// Throws wm::Error(key "--policies") naming the valid policies when `name` is none of them.
PolicyKind ParsePolicyKind(const std::string& name);
const std::vector<std::string>& AllPolicyNames();

class Policy {
 public:
  virtual ~Policy() = default;
  // The next action for state `s`, already within ClampAction's limits. Noise comes from
  // `rng`, so an episode is reproducible from its seed.
  virtual Action Act(const SceneState& s, Rng& rng) = 0;
};

// `initial` is the episode's first state (wrong_goal picks its decoy target from it).
std::unique_ptr<Policy> MakePolicy(PolicyKind kind, const SceneState& initial);

}  // namespace wm::tabletop

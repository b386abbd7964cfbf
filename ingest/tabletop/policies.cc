#include "ingest/tabletop/policies.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/error.h"

namespace wm::tabletop {
namespace {

constexpr double kHoverZ = 0.08;   // fingertips clear the block top (4 cm) with margin
constexpr double kGraspZ = 0.012;  // fingertips 1.2 cm above the table: around the block
constexpr double kCarryZ = 0.05;   // carried block bottom ~4 cm up: inside the goal volume
constexpr double kAligned = 0.012;

// Either pair of opposite block faces can be grasped, so yaw error is taken modulo 90 degrees.
double QuarterTurnError(double target, double current) {
  return std::remainder(target - current, std::numbers::pi / 2);
}

// Proportional step towards `target` (clamped by ClampAction), levelling roll and pitch.
Action MoveTowards(const SceneState& s, const Vec3& target, double yaw_error, double gripper) {
  return ClampAction({static_cast<float>(target.x - s.ee.x), static_cast<float>(target.y - s.ee.y),
                      static_cast<float>(target.z - s.ee.z), static_cast<float>(-s.ee_rpy.x),
                      static_cast<float>(-s.ee_rpy.y), static_cast<float>(yaw_error),
                      static_cast<float>(gripper)});
}

// The expert's closed-loop pick-and-place towards `place`; `at_place` reports when the block
// sits above `place` (wrong_goal then puts it down).
Action PickAndPlace(const SceneState& s, const Vec3& place, bool* at_place = nullptr) {
  if (at_place) *at_place = false;
  if (!s.holding) {
    const Vec3 above_block = {s.block.x, s.block.y, kHoverZ};
    const double yaw_error = QuarterTurnError(s.block_yaw, s.ee_rpy.z);
    const double distance = HorizontalDistance(s.ee, s.block);
    if (distance > 3 * kAligned && s.ee.z < s.block.z + kBlockHalfSize + 0.01) {
      return MoveTowards(s, {s.ee.x, s.ee.y, kHoverZ}, yaw_error, 0);  // lift before moving
    }
    if (distance > kAligned) return MoveTowards(s, above_block, yaw_error, 0);
    const Vec3 around_block = {s.block.x, s.block.y, kGraspZ};
    const bool lowered = s.ee.z <= kGraspZ + 0.004;
    // Closed but not holding means the grasp missed: open again so the next close can retry.
    const bool close = lowered && s.gripper < 0.5;
    return MoveTowards(s, around_block, yaw_error, close ? 1 : 0);
  }
  // Holding: move so that the block (not the tool point) ends above `place`.
  const Vec3 target = {s.ee.x + place.x - s.block.x, s.ee.y + place.y - s.block.y, kCarryZ};
  if (at_place) *at_place = HorizontalDistance(s.block, place) < 0.015;
  return MoveTowards(s, target, 0, 1);
}

class ExpertPolicy : public Policy {
 public:
  Action Act(const SceneState& s, Rng&) override { return PickAndPlace(s, s.goal); }
};

class NoisyPolicy : public Policy {
 public:
  Action Act(const SceneState& s, Rng& rng) override {
    Action a = PickAndPlace(s, s.goal);
    for (int i = 0; i < 3; ++i) a[i] += static_cast<float>(rng.Normal(0, 0.011));
    for (int i = 3; i < 6; ++i) a[i] += static_cast<float>(rng.Normal(0, 0.06));
    a[6] += static_cast<float>(rng.Normal(0, 0.25));  // ~2% of carrying steps drop the block
    return ClampAction(a);
  }
};

class RandomPolicy : public Policy {
 public:
  Action Act(const SceneState& s, Rng& rng) override {
    Action a;
    for (int i = 0; i < 3; ++i) a[i] = static_cast<float>(rng.Normal(0, 0.02));
    for (int i = 3; i < 6; ++i) a[i] = static_cast<float>(rng.Normal(0, 0.08));
    const bool flip = rng.Uniform() < 0.2;  // sticky gripper: mostly keeps its state
    const bool closed = s.gripper >= 0.5;
    a[6] = (closed != flip) ? 1.0f : 0.0f;
    return ClampAction(a);
  }
};

class WrongGoalPolicy : public Policy {
 public:
  // The decoy lies beyond the block, on the side away from the goal, so the carry never
  // crosses the goal region. It stays well inside the workspace so the block can reach it.
  explicit WrongGoalPolicy(const SceneState& initial) {
    Vec3 away = {initial.block.x - initial.goal.x, initial.block.y - initial.goal.y, 0};
    away = away * (0.18 / std::max(Norm(away), 1e-9));
    decoy_ = {std::clamp(initial.block.x + away.x, -0.2, 0.2),
              std::clamp(initial.block.y + away.y, -0.05, 0.4), 0};
  }
  Action Act(const SceneState& s, Rng&) override {
    if (placed_) return MoveTowards(s, {s.ee.x, s.ee.y, 2 * kHoverZ}, 0, 0);  // retreat, wait
    bool at_place = false;
    Action a = PickAndPlace(s, decoy_, &at_place);
    if (!at_place) return a;
    if (s.ee.z > kGraspZ + 0.004) {
      return MoveTowards(s, {s.ee.x, s.ee.y, kGraspZ}, 0, 1);  // lower the block
    }
    placed_ = true;
    return MoveTowards(s, s.ee, 0, 0);  // open: release the block at the decoy
  }

 private:
  Vec3 decoy_;
  bool placed_ = false;
};

}  // namespace

const std::vector<std::string>& AllPolicyNames() {
  static const std::vector<std::string> names = {"expert", "noisy", "random", "wrong_goal"};
  return names;
}

std::string PolicyName(PolicyKind kind) { return AllPolicyNames()[static_cast<int>(kind)]; }

PolicyKind ParsePolicyKind(const std::string& name) {
  const auto& names = AllPolicyNames();
  const auto it = std::find(names.begin(), names.end(), name);
  if (it == names.end()) {
    throw Error("unknown policy '" + name + "' (valid: expert, noisy, random, wrong_goal)",
                {.key = "--policies"});
  }
  return static_cast<PolicyKind>(it - names.begin());
}

std::unique_ptr<Policy> MakePolicy(PolicyKind kind, const SceneState& initial) {
  switch (kind) {
    case PolicyKind::kExpert:
      return std::make_unique<ExpertPolicy>();
    case PolicyKind::kNoisy:
      return std::make_unique<NoisyPolicy>();
    case PolicyKind::kRandom:
      return std::make_unique<RandomPolicy>();
    case PolicyKind::kWrongGoal:
      return std::make_unique<WrongGoalPolicy>(initial);
  }
  throw Error("invalid policy kind", {.key = "--policies"});
}

}  // namespace wm::tabletop

#pragma once
// The tabletop world of wm-gen-tabletop: a table plane (z = 0, metres, z up, y away from the
// camera), a flat circular goal region, one cube-shaped block and a two-finger gripper whose
// end effector moves by the 7-dim action. State and dynamics only; render.h draws it.
#include <array>
#include <string>

#include "ingest/tabletop/geometry.h"
#include "ingest/tabletop/rng.h"
#include "policy/action_limits.h"

namespace wm::tabletop {

// Δx, Δy, Δz (metres), Δroll, Δpitch, Δyaw (radians) of the end effector, then the gripper
// command in [0, 1] (1 = closed). ClampAction limits it to what StepScene applies.
using Action = std::array<float, 7>;

// Per-step action limits: |Δx|, |Δy|, |Δz| <= 4 cm, |Δroll|, |Δpitch|, |Δyaw| <= 0.25 rad; in
// policy/ because wm-eval --policy clamps a policy's actions exactly as StepScene does.
inline constexpr double kMaxTranslationStep = policy::kTabletopMaxTranslationStep;
inline constexpr double kMaxRotationStep = policy::kTabletopMaxRotationStep;

// End-effector workspace (tool point = centre between the fingertips), metres.
inline constexpr Vec3 kEeMin = {-0.25, -0.10, 0.005};
inline constexpr Vec3 kEeMax = {0.25, 0.40, 0.30};
inline constexpr double kMaxTilt = 0.6;  // |roll|, |pitch| limit, radians

inline constexpr double kBlockHalfSize = 0.02;  // 4 cm cube
inline constexpr double kGoalRadius = 0.055;
// The block counts as in the goal when its centre is within kGoalRadius (horizontally) and its
// bottom is below this height, i.e. resting on or carried just above the goal region.
inline constexpr double kGoalMaxBottom = 0.05;

// Gripper geometry in the end-effector frame (x = finger opening axis, z = up the fingers).
inline constexpr double kFingerHalfWidth = 0.006;  // along x
inline constexpr double kFingerHalfDepth = 0.012;  // along y
inline constexpr double kFingerLength = 0.05;      // fingertips at z = 0, palm at the top
inline constexpr double kGapOpen = 0.09;           // inner finger gap at gripper = 0
inline constexpr double kGapClosed = 0.012;        // inner finger gap at gripper = 1
inline constexpr double kPalmHalfWidth = 0.062, kPalmHalfDepth = 0.022, kPalmHalfHeight = 0.01;
inline constexpr double kRodHalfWidth = 0.02;  // vertical arm link from the palm upwards
inline constexpr double kRodTopZ = 1.2;        // above the camera, so it leaves the image top

struct SceneState {
  Vec3 ee;             // end-effector tool point, metres
  Vec3 ee_rpy;         // roll, pitch, yaw, radians
  double gripper = 0;  // 0 open .. 1 closed (follows the command immediately)
  Vec3 block;          // block centre
  double block_yaw = 0;
  bool holding = false;  // block grasped and carried with the gripper
  Vec3 hold_offset;      // block - ee while held
  Vec3 goal;             // goal centre (z = 0)
};

// Appearance::table_pattern of LookVariation::kPlain: no pattern.
inline constexpr int kPlainTablePattern = 3;

// Per-episode look: what varies between episodes besides the layout.
struct Appearance {
  Vec3 table_rgb;         // linear 0..1
  int table_pattern = 0;  // 0 wood grain, 1 checker, 2 speckle, kPlainTablePattern none
  double pattern_scale = 1, pattern_phase = 0;
  Vec3 block_rgb;
  std::string block_colour;  // the colour's name, used in the instruction
  Vec3 goal_rgb;
  Vec3 light_dir;  // unit vector towards the (directional) light
  double light_intensity = 0.8, ambient = 0.3;
  std::string instruction;
};

struct Scene {
  SceneState state;
  Appearance look;
};

// Where goal centres are drawn from (metres, table coordinates; inclusive). The default is the
// whole table, as wm-gen-tabletop has always drawn them; a smaller region gives a task variant
// (wm-gen-tabletop --goal-region): e.g. pretraining with goals on one side of the table and
// fine-tuning on goals on the other (make finetune, docs/tabletop.md).
struct GoalRegion {
  double x_min = -0.2, x_max = 0.2, y_min = -0.05, y_max = 0.35;
  bool Contains(const Vec3& p) const {
    return p.x >= x_min && p.x <= x_max && p.y >= y_min && p.y <= y_max;
  }
  bool operator==(const GoalRegion&) const = default;
};
// A region must lie within these bounds (where the arm can carry the block) and be at least
// kMinGoalRegionSide wide and deep, so its farthest corner is always outside a goal around the
// block (SampleScene's fallback).
inline constexpr GoalRegion kGoalRegionBounds = {-0.25, 0.25, -0.10, 0.40};
inline constexpr double kMinGoalRegionSide = 0.1;

// How much the look varies between episodes. kPlain keeps one untextured table colour and one
// light for every episode (block colours still vary): a scene an 8x8-token tokenizer
// reconstructs well, so a small world model's predictions can be judged on the arm's motion
// rather than on texture it cannot encode (docs/tabletop.md).
enum class LookVariation { kVaried, kPlain };

// Samples layout and look. The block starts 15-30 cm from the goal, never inside it; the goal
// centre lies in `goals`. The layout does not depend on `variation`: the same seed gives the
// same episode in either look. With the default region the draws and results are those of
// wm-gen-tabletop before regions existed. A block that no goal of a small region can be 15-30 cm
// from (the 1000 tries fail) gets the region's corner farthest from it.
Scene SampleScene(Rng& rng, LookVariation variation = LookVariation::kVaried,
                  const GoalRegion& goals = {});

Action ClampAction(Action a);
// One control step: moves the end effector, applies the gripper command, grasps (closing
// around the block), releases (opening drops the block on the table) and pushes the block
// with the fingers when they touch it.
void StepScene(SceneState& s, const Action& a);
bool BlockInGoal(const SceneState& s);
// Inner gap between the fingers for the current gripper value (never narrower than a held
// block).
double FingerGap(const SceneState& s);

}  // namespace wm::tabletop

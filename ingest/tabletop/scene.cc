#include "ingest/tabletop/scene.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

namespace wm::tabletop {
namespace {

constexpr double kPi = std::numbers::pi;

struct NamedColour {
  const char* name = nullptr;
  Vec3 rgb;
};
// No green among block or table colours: green is the goal's colour.
constexpr NamedColour kBlockColours[] = {
    {"red", {0.85, 0.12, 0.10}},    {"blue", {0.12, 0.25, 0.85}},   {"yellow", {0.92, 0.80, 0.12}},
    {"orange", {0.95, 0.48, 0.08}}, {"purple", {0.55, 0.18, 0.70}}, {"white", {0.92, 0.92, 0.90}}};
constexpr Vec3 kTableColours[] = {{0.55, 0.38, 0.22},
                                  {0.62, 0.60, 0.56},
                                  {0.80, 0.72, 0.58},
                                  {0.30, 0.32, 0.38},
                                  {0.50, 0.55, 0.65}};
constexpr const char* kInstructionTemplates[] = {
    "push the {} block to the green goal", "move the {} block onto the green goal",
    "put the {} block in the green goal region", "bring the {} block to the green circle"};

double Clamp(double v, double lo, double hi) { return std::min(std::max(v, lo), hi); }
double WrapAngle(double a) { return std::remainder(a, 2 * kPi); }

std::string FormatInstruction(const char* tmpl, const std::string& colour) {
  std::string s = tmpl;
  s.replace(s.find("{}"), 2, colour);
  return s;
}

Appearance SampleAppearance(Rng& rng) {
  Appearance look;
  const Vec3 base = kTableColours[rng.Index(std::size(kTableColours))];
  look.table_rgb = {Clamp(base.x + rng.Uniform(-0.05, 0.05), 0, 1),
                    Clamp(base.y + rng.Uniform(-0.05, 0.05), 0, 1),
                    Clamp(base.z + rng.Uniform(-0.05, 0.05), 0, 1)};
  look.table_pattern = static_cast<int>(rng.Index(3));
  look.pattern_scale = rng.Uniform(0.7, 1.4);
  look.pattern_phase = rng.Uniform(0, 2 * kPi);
  const NamedColour& block = kBlockColours[rng.Index(std::size(kBlockColours))];
  look.block_rgb = block.rgb;
  look.block_colour = block.name;
  look.goal_rgb = {0.15, 0.68, 0.22};
  const double azimuth = rng.Uniform(0, 2 * kPi);
  const double elevation = rng.Uniform(35, 75) * kPi / 180;
  look.light_dir = {std::cos(elevation) * std::cos(azimuth),
                    std::cos(elevation) * std::sin(azimuth), std::sin(elevation)};
  look.light_intensity = rng.Uniform(0.55, 0.9);
  look.ambient = rng.Uniform(0.2, 0.35);
  look.instruction = FormatInstruction(
      kInstructionTemplates[rng.Index(std::size(kInstructionTemplates))], look.block_colour);
  return look;
}

// Fingers are discs in the horizontal plane for pushing; the block a slightly larger disc.
void PushBlock(SceneState& s) {
  if (s.ee.z >= s.block.z + kBlockHalfSize) return;  // fingertips above the block top
  constexpr double kFingerRadius = 0.01, kBlockRadius = 1.2 * kBlockHalfSize;
  const Mat3 r = RotationFromRpy(s.ee_rpy.x, s.ee_rpy.y, s.ee_rpy.z);
  const double offset = FingerGap(s) / 2 + kFingerHalfWidth;
  for (double side : {-1.0, 1.0}) {
    const Vec3 finger = s.ee + r * Vec3{side * offset, 0, 0};
    Vec3 away = {s.block.x - finger.x, s.block.y - finger.y, 0};
    const double d = Norm(away);
    const double contact = kFingerRadius + kBlockRadius;
    if (d >= contact) continue;
    away = d > 1e-9 ? away * (1.0 / d) : Vec3{1, 0, 0};
    s.block = s.block + away * (contact - d);
  }
}

bool CanGrasp(const SceneState& s) {
  return HorizontalDistance(s.ee, s.block) < 0.02 &&
         s.ee.z < s.block.z + kBlockHalfSize - 0.01;  // fingertips reach 1 cm below the top
}

// The fixed parts of LookVariation::kPlain, applied after sampling so the draws stay the same.
void MakePlain(Appearance& look) {
  look.table_rgb = kTableColours[1];
  look.table_pattern = kPlainTablePattern;
  look.light_dir = Normalized(Vec3{0.3, -0.4, 0.87});
  look.light_intensity = 0.75;
  look.ambient = 0.3;
}

// The corner of `region` farthest from `p` (horizontally).
Vec3 FarthestCorner(const GoalRegion& region, const Vec3& p) {
  return {p.x - region.x_min > region.x_max - p.x ? region.x_min : region.x_max,
          p.y - region.y_min > region.y_max - p.y ? region.y_min : region.y_max, 0};
}

}  // namespace

Scene SampleScene(Rng& rng, LookVariation variation, const GoalRegion& goals) {
  Scene scene;
  scene.look = SampleAppearance(rng);
  if (variation == LookVariation::kPlain) MakePlain(scene.look);
  SceneState& s = scene.state;
  s.block = {rng.Uniform(-0.16, 0.16), rng.Uniform(0.0, 0.3), kBlockHalfSize};
  s.block_yaw = rng.Uniform(-kPi / 4, kPi / 4);
  // Rejection sampling for the goal; 1000 tries of a ~25% acceptance never all fail in
  // practice, and the fallback keeps the function total and deterministic.
  s.goal = {s.block.x > 0 ? s.block.x - 0.2 : s.block.x + 0.2, s.block.y, 0};
  if (!goals.Contains(s.goal)) s.goal = FarthestCorner(goals, s.block);  // never on the default
  for (int attempt = 0; attempt < 1000; ++attempt) {
    const Vec3 g = {rng.Uniform(goals.x_min, goals.x_max), rng.Uniform(goals.y_min, goals.y_max),
                    0};
    const double d = HorizontalDistance(g, s.block);
    if (d >= 0.15 && d <= 0.3) {
      s.goal = g;
      break;
    }
  }
  s.ee = {rng.Uniform(-0.2, 0.2), rng.Uniform(-0.05, 0.3), rng.Uniform(0.12, 0.22)};
  s.ee_rpy = {0, 0, rng.Uniform(-0.6, 0.6)};
  s.gripper = 0;
  return scene;
}

Action ClampAction(Action a) {
  policy::ClampTabletopAction(a.data());
  return a;
}

void StepScene(SceneState& s, const Action& action) {
  const Action a = ClampAction(action);
  s.ee = {Clamp(s.ee.x + a[0], kEeMin.x, kEeMax.x), Clamp(s.ee.y + a[1], kEeMin.y, kEeMax.y),
          Clamp(s.ee.z + a[2], kEeMin.z, kEeMax.z)};
  s.ee_rpy = {Clamp(s.ee_rpy.x + a[3], -kMaxTilt, kMaxTilt),
              Clamp(s.ee_rpy.y + a[4], -kMaxTilt, kMaxTilt), WrapAngle(s.ee_rpy.z + a[5])};
  const double previous_gripper = std::exchange(s.gripper, a[6]);
  if (s.holding && s.gripper < 0.5) {
    s.holding = false;  // opening drops the block onto the table
    s.block.z = kBlockHalfSize;
  } else if (s.holding) {
    s.block = s.ee + s.hold_offset;
    s.block.z = std::max(s.block.z, kBlockHalfSize);  // the table stops a lowered block
    s.block_yaw = WrapAngle(s.block_yaw + a[5]);
  } else if (s.gripper >= 0.5 && previous_gripper < 0.5 && CanGrasp(s)) {
    s.holding = true;
    s.hold_offset = s.block - s.ee;
  } else {
    PushBlock(s);
  }
  // The block may be pushed around but stays in view.
  s.block.x = Clamp(s.block.x, -0.3, 0.3);
  s.block.y = Clamp(s.block.y, -0.12, 0.5);
}

bool BlockInGoal(const SceneState& s) {
  return HorizontalDistance(s.block, s.goal) < kGoalRadius &&
         s.block.z - kBlockHalfSize < kGoalMaxBottom;
}

double FingerGap(const SceneState& s) {
  const double gap = kGapOpen + (kGapClosed - kGapOpen) * s.gripper;
  return s.holding ? std::max(gap, 2 * kBlockHalfSize) : gap;
}

}  // namespace wm::tabletop

#include "ingest/tabletop/render.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace wm::tabletop {
namespace {

constexpr double kFieldOfView = 45.0 * std::numbers::pi / 180;
constexpr double kHitEpsilon = 1e-7;

// An oriented box: every solid in the scene (block, fingers, palm, arm link) is one.
struct Solid {
  Vec3 center;
  Mat3 rot;
  Vec3 half;
  Vec3 albedo;
  Label label;
  // Vertical box reaching above the view (the arm link): bounded by its part below the top of
  // the view frustum, since its corners lie behind the camera.
  bool clip_to_view = false;
};

// Pixel rectangle [u0, u1) x [v0, v1) outside which a solid (or its shadow) cannot appear.
struct Rect {
  int u0 = 0, v0 = 0, u1 = 0, v1 = 0;
  bool Contains(int u, int v) const { return u >= u0 && u < u1 && v >= v0 && v < v1; }
};

// Slab test in the box frame; returns the entry distance and the world normal of the entry
// face. Rays starting inside a box miss it (shadow rays start on a surface, offset outwards).
bool HitSolid(const Solid& s, const Vec3& origin, const Vec3& dir, double* t, Vec3* normal) {
  const Vec3 lo = s.rot.TransposeTimes(origin - s.center);
  const Vec3 ld = s.rot.TransposeTimes(dir);
  const double o[3] = {lo.x, lo.y, lo.z}, d[3] = {ld.x, ld.y, ld.z};
  const double h[3] = {s.half.x, s.half.y, s.half.z};
  double t_near = -std::numeric_limits<double>::infinity();
  double t_far = std::numeric_limits<double>::infinity();
  int axis = -1;
  double sign = 0;
  for (int i = 0; i < 3; ++i) {
    if (std::abs(d[i]) < 1e-12) {
      if (std::abs(o[i]) > h[i]) return false;
      continue;
    }
    double t1 = (-h[i] - o[i]) / d[i], t2 = (h[i] - o[i]) / d[i];
    double face = -1;  // entering through the -h face when moving towards +axis
    if (t1 > t2) {
      std::swap(t1, t2);
      face = 1;
    }
    if (t1 > t_near) {
      t_near = t1;
      axis = i;
      sign = face;
    }
    t_far = std::min(t_far, t2);
    if (t_near > t_far) return false;
  }
  if (axis < 0 || t_near < kHitEpsilon) return false;
  *t = t_near;
  *normal = s.rot.col[axis] * sign;
  return true;
}

std::vector<Solid> BuildSolids(const Scene& scene, bool draw_robot) {
  const SceneState& s = scene.state;
  std::vector<Solid> solids;
  solids.push_back({s.block,
                    RotationFromRpy(0, 0, s.block_yaw),
                    {kBlockHalfSize, kBlockHalfSize, kBlockHalfSize},
                    scene.look.block_rgb,
                    kLabelBlock});
  if (!draw_robot) return solids;
  const Mat3 r = RotationFromRpy(s.ee_rpy.x, s.ee_rpy.y, s.ee_rpy.z);
  const double finger_x = FingerGap(s) / 2 + kFingerHalfWidth;
  for (double side : {-1.0, 1.0}) {
    solids.push_back({s.ee + r * Vec3{side * finger_x, 0, kFingerLength / 2},
                      r,
                      {kFingerHalfWidth, kFingerHalfDepth, kFingerLength / 2},
                      {0.22, 0.22, 0.25},
                      kLabelRobot});
  }
  solids.push_back({s.ee + r * Vec3{0, 0, kFingerLength + kPalmHalfHeight},
                    r,
                    {kPalmHalfWidth, kPalmHalfDepth, kPalmHalfHeight},
                    {0.55, 0.56, 0.60},
                    kLabelRobot});
  // The arm link stays vertical (a gantry-style arm); it turns with the wrist's yaw only.
  const Vec3 wrist = s.ee + r * Vec3{0, 0, kFingerLength + 2 * kPalmHalfHeight};
  const double half_length = std::max(kRodTopZ - wrist.z, 0.01) / 2;
  solids.push_back({{wrist.x, wrist.y, wrist.z + half_length},
                    RotationFromRpy(0, 0, s.ee_rpy.z),
                    {kRodHalfWidth, kRodHalfWidth, half_length},
                    {0.75, 0.75, 0.78},
                    kLabelRobot,
                    /*clip_to_view=*/true});
  return solids;
}

// Screen bounds of a set of points; the whole image when any lies near or behind the camera.
Rect ProjectBounds(const std::vector<Vec3>& points, const CameraPose& cam,
                   const CameraIntrinsics& k, int size) {
  double u_min = 1e9, u_max = -1e9, v_min = 1e9, v_max = -1e9;
  for (const Vec3& p : points) {
    const Vec3 rel = p - cam.position;
    const double z = Dot(rel, cam.forward);
    if (z < 0.05) return {0, 0, size, size};
    const double u = k.fx * Dot(rel, cam.right) / z + k.cx;
    const double v = k.fy * Dot(rel, cam.down) / z + k.cy;
    u_min = std::min(u_min, u), u_max = std::max(u_max, u);
    v_min = std::min(v_min, v), v_max = std::max(v_max, v);
  }
  auto lo = [&](double x) { return std::clamp(static_cast<int>(std::floor(x)) - 1, 0, size); };
  auto hi = [&](double x) { return std::clamp(static_cast<int>(std::ceil(x)) + 2, 0, size); };
  return {lo(u_min), lo(v_min), hi(u_max), hi(v_max)};
}

// Lowers each corner of a vertical box to where its vertical edge leaves the view through the
// top plane of the frustum (never below its own bottom); the result bounds the visible part.
void ClipToViewTop(std::vector<Vec3>& corners, const CameraPose& cam, const CameraIntrinsics& k) {
  const Vec3 top_edge = cam.forward - cam.down * (k.cy / k.fy);  // ray through image row 0
  Vec3 outward = Normalized(Cross(top_edge, cam.right));
  if (Dot(outward, cam.down) > 0) outward = outward * -1.0;
  if (outward.z <= 1e-6) return;  // the top plane is vertical or tilted back: no clipping
  double bottom = corners[0].z;
  for (const Vec3& c : corners) bottom = std::min(bottom, c.z);
  for (Vec3& c : corners) {
    const double crossing = c.z - Dot(c - cam.position, outward) / outward.z;
    c.z = std::max(bottom, std::min(c.z, crossing + 0.005));
  }
}

std::vector<Vec3> Corners(const Solid& s) {
  std::vector<Vec3> corners;
  for (int i = 0; i < 8; ++i) {
    const Vec3 local = {(i & 1 ? 1 : -1) * s.half.x, (i & 2 ? 1 : -1) * s.half.y,
                        (i & 4 ? 1 : -1) * s.half.z};
    corners.push_back(s.center + s.rot * local);
  }
  return corners;
}

// Integer hash -> [0, 1): deterministic value noise for the speckled table.
double HashNoise(int64_t a, int64_t b) {
  uint64_t h = MixBits(static_cast<uint64_t>(a) * 0x9e3779b97f4a7c15ULL ^ static_cast<uint64_t>(b));
  return static_cast<double>(h >> 11) * 0x1.0p-53;
}

Vec3 TableAlbedo(const Vec3& p, const Scene& scene, Label* label) {
  const Appearance& look = scene.look;
  const double goal_distance = HorizontalDistance(p, scene.state.goal);
  if (goal_distance < kGoalRadius) {
    *label = kLabelGoal;
    return look.goal_rgb * (goal_distance > kGoalRadius - 0.006 ? 0.6 : 1.0);  // dark rim
  }
  *label = kLabelTable;
  const double s = look.pattern_scale;
  double shade = 1;
  switch (look.table_pattern) {
    case 0:  // wood grain: stripes along x, wavy in y
      shade = 1 + 0.12 * std::sin(60 * s * (p.x + 0.02 * std::sin(20 * p.y)) + look.pattern_phase);
      break;
    case 1: {  // checker board, ~5 cm cells
      const double cell = 0.05 * s;
      const auto parity = static_cast<int64_t>(std::floor(p.x / cell) + std::floor(p.y / cell));
      shade = (parity & 1) ? 0.86 : 1.06;
      break;
    }
    case kPlainTablePattern:
      break;
    default:  // speckle, 4 mm grains
      shade = 0.88 + 0.24 * HashNoise(static_cast<int64_t>(std::floor(p.x / (0.004 * s))),
                                      static_cast<int64_t>(std::floor(p.y / (0.004 * s))));
  }
  return look.table_rgb * shade;
}

struct RayHit {
  double t = std::numeric_limits<double>::infinity();  // distance along the unit ray
  Vec3 normal = {0, 0, 1};
  int solid = -1;  // index into the solids, -1 for the table plane
};

RayHit CastCameraRay(const Vec3& origin, const Vec3& dir, const std::vector<Solid>& solids,
                     const std::vector<Rect>& bounds, int u, int v) {
  RayHit hit;
  if (dir.z < 0) hit.t = -origin.z / dir.z;  // the table plane z = 0
  for (size_t i = 0; i < solids.size(); ++i) {
    double t;
    Vec3 normal;
    if (bounds[i].Contains(u, v) && HitSolid(solids[i], origin, dir, &t, &normal) && t < hit.t) {
      hit = {t, normal, static_cast<int>(i)};
    }
  }
  return hit;
}

// Whether another solid blocks the light at `p`. A box never shadows its own lit faces, and
// table points only need the solids whose shadow bounds hold the pixel.
bool InShadow(const Vec3& p, const RayHit& hit, const Vec3& light, const std::vector<Solid>& solids,
              const std::vector<Rect>& shadow_bounds, int u, int v) {
  for (size_t j = 0; j < solids.size(); ++j) {
    if (static_cast<int>(j) == hit.solid) continue;
    if (hit.solid < 0 && !shadow_bounds[j].Contains(u, v)) continue;
    double t;
    Vec3 normal;
    if (HitSolid(solids[j], p + hit.normal * 1e-5, light, &t, &normal)) return true;
  }
  return false;
}

uint8_t ToByte(double v) {
  return static_cast<uint8_t>(std::clamp(v, 0.0, 1.0) * 255 + 0.5);  // round half up
}

}  // namespace

CameraIntrinsics IntrinsicsForSize(int size) {
  const float f = static_cast<float>(size / (2 * std::tan(kFieldOfView / 2)));
  const float c = static_cast<float>(size - 1) / 2;
  return {f, f, c, c};
}

CameraPose TableCamera() {
  const Vec3 position = {0, -0.25, 0.5}, target = {0, 0.15, 0};
  const Vec3 forward = Normalized(target - position);
  const Vec3 right = Normalized(Cross(forward, {0, 0, 1}));
  return {position, right, Cross(forward, right), forward};
}

Frame RenderFrame(const Scene& scene, int size, const RenderOptions& options) {
  const CameraIntrinsics k = IntrinsicsForSize(size);
  const CameraPose cam = TableCamera();
  const Appearance& look = scene.look;
  const Vec3 light = Normalized(look.light_dir);
  const std::vector<Solid> solids = BuildSolids(scene, options.draw_robot);
  std::vector<Rect> bounds, shadow_bounds;
  for (const Solid& s : solids) {
    if (!options.cull) {
      bounds.push_back({0, 0, size, size});
      shadow_bounds.push_back({0, 0, size, size});
      continue;
    }
    std::vector<Vec3> corners = Corners(s);
    std::vector<Vec3> visible = corners;
    if (s.clip_to_view) ClipToViewTop(visible, cam, k);
    bounds.push_back(ProjectBounds(visible, cam, k, size));
    for (Vec3& c : corners) c = c - light * (c.z / light.z);  // shadow on the table plane
    shadow_bounds.push_back(ProjectBounds(corners, cam, k, size));
  }
  const size_t pixels = static_cast<size_t>(size) * size;
  Frame frame{size, std::vector<uint8_t>(3 * pixels), std::vector<uint16_t>(pixels),
              std::vector<uint8_t>(pixels)};
  for (int v = 0; v < size; ++v) {
    for (int u = 0; u < size; ++u) {
      const Vec3 dir = Normalized(cam.right * ((u - k.cx) / k.fx) + cam.down * ((v - k.cy) / k.fy) +
                                  cam.forward);
      const RayHit hit = CastCameraRay(cam.position, dir, solids, bounds, u, v);
      const size_t px = static_cast<size_t>(v) * size + u;
      if (!std::isfinite(hit.t)) continue;  // sky: black, depth 0 (unknown); never in view
      const Vec3 p = cam.position + dir * hit.t;
      Label label = kLabelTable;
      const Vec3 albedo = hit.solid < 0 ? TableAlbedo(p, scene, &label) : solids[hit.solid].albedo;
      if (hit.solid >= 0) label = solids[hit.solid].label;
      double diffuse = std::max(0.0, Dot(hit.normal, light));
      if (options.shadows && diffuse > 0 && InShadow(p, hit, light, solids, shadow_bounds, u, v)) {
        diffuse = 0;
      }
      const Vec3 colour = albedo * (look.ambient + look.light_intensity * diffuse);
      frame.rgb[3 * px] = ToByte(colour.x);
      frame.rgb[3 * px + 1] = ToByte(colour.y);
      frame.rgb[3 * px + 2] = ToByte(colour.z);
      const double depth_mm = std::round(hit.t * Dot(dir, cam.forward) * 1000);  // Z, not range
      frame.depth_mm[px] = static_cast<uint16_t>(std::clamp(depth_mm, 0.0, 65535.0));
      frame.labels[px] = label;
    }
  }
  return frame;
}

}  // namespace wm::tabletop

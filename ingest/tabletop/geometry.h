#pragma once
// Minimal 3-D vector and rotation types for the tabletop scene (metres, radians, right-handed,
// z up). Kept tiny and header-only so the scene needs no linear-algebra dependency.
#include <cmath>

namespace wm::tabletop {

struct Vec3 {
  double x = 0, y = 0, z = 0;
  Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
  Vec3 operator*(const Vec3& o) const { return {x * o.x, y * o.y, z * o.z}; }  // per component
};

inline double Dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 Cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double Norm(const Vec3& a) { return std::sqrt(Dot(a, a)); }
inline Vec3 Normalized(const Vec3& a) { return a * (1.0 / Norm(a)); }
// Distance in the table plane (x, y), ignoring height.
inline double HorizontalDistance(const Vec3& a, const Vec3& b) {
  return std::sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y));
}

// Rotation matrix stored by columns: col[i] is the body's i-th axis expressed in world frame.
struct Mat3 {
  Vec3 col[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  Vec3 operator*(const Vec3& v) const { return col[0] * v.x + col[1] * v.y + col[2] * v.z; }
  Vec3 TransposeTimes(const Vec3& v) const {
    return {Dot(col[0], v), Dot(col[1], v), Dot(col[2], v)};
  }
  Mat3 operator*(const Mat3& o) const {
    Mat3 m;
    for (int i = 0; i < 3; ++i) m.col[i] = (*this) * o.col[i];
    return m;
  }
};

// Extrinsic x-y-z (roll, pitch, yaw) rotation: R = Rz(yaw) * Ry(pitch) * Rx(roll).
inline Mat3 RotationFromRpy(double roll, double pitch, double yaw) {
  const double cr = std::cos(roll), sr = std::sin(roll);
  const double cp = std::cos(pitch), sp = std::sin(pitch);
  const double cy = std::cos(yaw), sy = std::sin(yaw);
  Mat3 m;
  m.col[0] = {cy * cp, sy * cp, -sp};
  m.col[1] = {cy * sp * sr - sy * cr, sy * sp * sr + cy * cr, cp * sr};
  m.col[2] = {cy * sp * cr + sy * sr, sy * sp * cr - cy * sr, cp * cr};
  return m;
}

}  // namespace wm::tabletop

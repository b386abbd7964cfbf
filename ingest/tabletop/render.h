#pragma once
// Per-pixel ray casting of a tabletop Scene through a fixed pinhole camera. One ray per pixel
// produces colour, depth and label together, so the three images agree exactly.
#include <cstdint>
#include <vector>

#include "ingest/tabletop/geometry.h"
#include "ingest/tabletop/scene.h"

namespace wm::tabletop {

enum Label : uint8_t { kLabelTable = 0, kLabelRobot = 1, kLabelBlock = 2, kLabelGoal = 3 };

// OpenCV convention: pixel (u, v) sees direction right * (u - cx) / fx + down * (v - cy) / fy
// + forward, so a pixel with depth Z (metres) back-projects to X = (u - cx) Z / fx, etc.
struct CameraIntrinsics {
  float fx = 0, fy = 0, cx = 0, cy = 0;
};
// A square image `size` pixels wide with a 45 degree field of view.
CameraIntrinsics IntrinsicsForSize(int size);

// The camera's pose in the table frame: it sits 50 cm above the table, 40 cm in front of the
// workspace centre (0, 0.15, 0) it looks at, i.e. 51 degrees down. Fixed for every episode.
struct CameraPose {
  Vec3 position, right, down, forward;  // forward = optical axis; all unit vectors
};
CameraPose TableCamera();

struct Frame {
  int size = 0;
  std::vector<uint8_t> rgb;        // [size, size, 3], row-major, RGB order
  std::vector<uint16_t> depth_mm;  // [size, size], Z along the optical axis, millimetres
  std::vector<uint8_t> labels;     // [size, size], Label values
};

struct RenderOptions {
  bool draw_robot = true;  // false renders the same scene without the arm and gripper
  bool shadows = true;     // hard shadows of block and robot from the directional light
  // Tests rays only against solids whose screen bounds hold the pixel. Speed only: false is the
  // brute-force reference, which must give identical images.
  bool cull = true;
};

Frame RenderFrame(const Scene& scene, int size, const RenderOptions& options = {});

}  // namespace wm::tabletop

#pragma once
// Where region maps come from. Three methods behind one interface, each turning the reference
// (ground-truth) video, plus what it needs besides, into one RegionMap per frame:
//   files   label images per frame (a dataset's segmentation stream) mapped by a LabelMap
//   motion  the moving robot in the RGB video: temporal-median background, shadow-tolerant
//           differencing, morphology, connected components entering from the arm's border
//   depth   depth frames back-projected with the camera intrinsics: RANSAC table plane, Euclidean
//           clusters, the border-touching cluster is the arm, the others objects (PCL)
// Algorithms, parameters and measured accuracy: docs/metrics-segmentation.md.
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "metrics/image_io.h"
#include "metrics/segmentation/region_map.h"

namespace wm::metrics::seg {

class MaskSource {
 public:
  virtual ~MaskSource() = default;
  // One map per reference frame, each the frame's size. Throws wm::Error naming the file that
  // does not fit (count, size, content).
  virtual std::vector<RegionMap> Masks(const Frames& reference) const = 0;
  // "files", "motion" or "depth".
  virtual std::string name() const = 0;
};

// Label value of a segmentation image -> region.
struct LabelMap {
  std::map<int, Region> regions;
  // Region of a label that `regions` does not list; empty: such a label is an error.
  std::optional<Region> unlisted;

  // Throws wm::Error naming the label when it is unlisted and `unlisted` is empty.
  Region Lookup(int label) const;
  // Throws wm::Error when `regions` is empty.
  void Check() const;
};

// The image borders the robot arm enters the view from: a connected part touching one of them
// can be the arm. Tabletop (and most fixed third-person cameras): the top.
struct ArmBorders {
  bool top = true, bottom = false, left = false, right = false;
  // "top", "top,left", ...; throws wm::Error on another word or an empty list.
  static ArmBorders Parse(const std::string& list);
  std::string ToString() const;
  bool Touches(int y, int x, int height, int width) const;
};

struct MotionMaskOptions {
  // A pixel changed when some channel differs by more than this fraction of the data range
  // (from the background, or between the colours ("modes") a pixel shows over the episode).
  double change_threshold = 0.04;
  // A colour must be seen in at least this many frames to be a pixel's background.
  int min_mode_frames = 2;
  // Pixels; the static scene's colours are learned this far away from anything that moves.
  int static_margin = 8;
  // Shadow test (Horprasert et al. 1999, as MOG2's detectShadows): a changed pixel whose colour
  // is the background's times the shadow ratio (within shadow_ratio_tolerance), with a colour
  // distortion of at most shadow_max_distortion (fraction of the background's norm), is the
  // background in the robot's shadow, not the robot.
  bool shadows = true;
  double shadow_ratio = 0;  // 0: the peak of the video's brightness ratios (one light, one table)
  double shadow_ratio_tolerance = 0.06;
  double shadow_max_distortion = 0.03;
  int open_radius = 1;   // pixels; removes compression speckle
  int close_radius = 2;  // pixels; bridges gaps where the arm matches the background colour
  // Connected parts smaller than this fraction of the frame are ignored.
  double min_part_fraction = 0.001;
  ArmBorders arm_borders;

  void Check() const;  // throws wm::Error naming the field
};

struct CameraIntrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;  // pixels, OpenCV pinhole convention
  // "fx,fy,cx,cy"; throws wm::Error unless four numbers with positive focal lengths.
  static CameraIntrinsics Parse(const std::string& text);
};

struct DepthMaskOptions {
  std::optional<CameraIntrinsics> intrinsics;  // required
  double depth_scale = 0.001;       // metres per depth unit (16-bit millimetre PNGs: 0.001)
  double plane_distance = 0.01;     // metres; RANSAC inlier distance to the table plane
  int plane_iterations = 200;       // RANSAC iterations
  double cluster_tolerance = 0.02;  // metres; Euclidean clustering neighbour distance
  int min_cluster_points = 20;      // smaller clusters are no region (noise, fringes)
  ArmBorders arm_borders;

  void Check() const;  // throws wm::Error naming the field
};

// `labels`: one single-channel label image per reference frame (integer values).
std::unique_ptr<MaskSource> MakeFileMaskSource(Frames labels, LabelMap map);
std::unique_ptr<MaskSource> MakeMotionMaskSource(const MotionMaskOptions& options);
// `depth`: one single-channel depth image per reference frame; 0 means no measurement.
std::unique_ptr<MaskSource> MakeDepthMaskSource(Frames depth, const DepthMaskOptions& options);

// Shared by the sources: throws wm::Error naming `what`'s file unless it holds one frame per
// reference frame, each single-channel and of the reference frames' size.
void CheckAlongside(const Frames& what, const std::string& kind, const Frames& reference);

}  // namespace wm::metrics::seg

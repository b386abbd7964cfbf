// Depth masks: the table is the dominant plane, everything standing on it is a cluster of
// points above it, and the arm is the cluster that enters the view from its border. PCL stays
// in this file (its headers are the heaviest in the build).
#include <pcl/ModelCoefficients.h>
#include <pcl/PointIndices.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>
#include <pcl/segmentation/sac_segmentation.h>

#include "core/error.h"
#include "metrics/segmentation/mask_source.h"

namespace wm::metrics::seg {
namespace {

// The frame's valid pixels as 3-D points in the camera frame (metres), and which pixel each
// point came from.
struct PixelCloud {
  pcl::PointCloud<pcl::PointXYZ>::Ptr points{new pcl::PointCloud<pcl::PointXYZ>};
  std::vector<int> pixel;  // row-major pixel index per point
};

// Pinhole back-projection: pixel (u, v) at depth Z is ((u - cx) Z / fx, (v - cy) Z / fy, Z).
PixelCloud BackProject(const Image& depth, const DepthMaskOptions& o) {
  const CameraIntrinsics& k = *o.intrinsics;
  PixelCloud cloud;
  for (int v = 0; v < depth.height; ++v) {
    for (int u = 0; u < depth.width; ++u) {
      const double z = depth.at(v, u, 0) * o.depth_scale;
      if (!(z > 0)) continue;  // 0: no measurement (and NaN)
      cloud.points->push_back(pcl::PointXYZ(static_cast<float>((u - k.cx) * z / k.fx),
                                            static_cast<float>((v - k.cy) * z / k.fy),
                                            static_cast<float>(z)));
      cloud.pixel.push_back(v * depth.width + u);
    }
  }
  return cloud;
}

// Indices of the points within plane_distance of the dominant plane (RANSAC). PCL seeds its
// generator with a constant unless asked not to, so the result is the same on every run.
pcl::PointIndices TablePlane(const PixelCloud& cloud, const DepthMaskOptions& o) {
  pcl::SACSegmentation<pcl::PointXYZ> sac;
  sac.setOptimizeCoefficients(true);
  sac.setModelType(pcl::SACMODEL_PLANE);
  sac.setMethodType(pcl::SAC_RANSAC);
  sac.setDistanceThreshold(o.plane_distance);
  sac.setMaxIterations(o.plane_iterations);
  sac.setNumberOfThreads(1);  // one thread: the same inliers whatever the machine
  sac.setInputCloud(cloud.points);
  pcl::PointIndices inliers;
  pcl::ModelCoefficients plane;
  sac.segment(inliers, plane);
  return inliers;
}

// Euclidean clusters of the points off the plane, largest first.
std::vector<pcl::PointIndices> ClustersOffPlane(const PixelCloud& cloud,
                                                const pcl::PointIndices& plane,
                                                const DepthMaskOptions& o) {
  std::vector<bool> on_plane(cloud.pixel.size(), false);
  for (int i : plane.indices) on_plane[i] = true;
  pcl::IndicesPtr rest(new pcl::Indices);
  for (size_t i = 0; i < on_plane.size(); ++i) {
    if (!on_plane[i]) rest->push_back(static_cast<int>(i));
  }
  std::vector<pcl::PointIndices> clusters;
  if (rest->empty()) return clusters;
  pcl::search::KdTree<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>);
  pcl::EuclideanClusterExtraction<pcl::PointXYZ> extract;
  extract.setClusterTolerance(o.cluster_tolerance);
  extract.setMinClusterSize(o.min_cluster_points);
  extract.setMaxClusterSize(static_cast<int>(cloud.pixel.size()));
  extract.setSearchMethod(tree);
  extract.setInputCloud(cloud.points);
  extract.setIndices(rest);
  extract.extract(clusters);
  return clusters;
}

// The plane is background; the largest cluster touching an arm border is the arm, the other
// clusters objects; small clusters and pixels without depth are in no region.
RegionMap AssignRegions(const Image& depth, const PixelCloud& cloud, const pcl::PointIndices& plane,
                        const std::vector<pcl::PointIndices>& clusters, const DepthMaskOptions& o) {
  RegionMap map(depth.height, depth.width);
  for (int i : plane.indices) map.pixels[cloud.pixel[i]] = Region::kBackground;
  auto touches_border = [&](const pcl::PointIndices& cluster) {
    for (int i : cluster.indices) {
      const int p = cloud.pixel[i];
      if (o.arm_borders.Touches(p / depth.width, p % depth.width, depth.height, depth.width)) {
        return true;
      }
    }
    return false;
  };
  // PCL sorts clusters by size (largest first), so the first border-touching one is the arm.
  bool arm_found = false;
  for (const pcl::PointIndices& cluster : clusters) {
    const bool is_arm = !arm_found && touches_border(cluster);
    arm_found = arm_found || is_arm;
    for (int i : cluster.indices) {
      map.pixels[cloud.pixel[i]] = is_arm ? Region::kArm : Region::kObject;
    }
  }
  return map;
}

class DepthMaskSource : public MaskSource {
 public:
  DepthMaskSource(Frames depth, const DepthMaskOptions& options)
      : depth_(std::move(depth)), options_(options) {
    options_.Check();
  }
  std::string name() const override { return "depth"; }

  std::vector<RegionMap> Masks(const Frames& reference) const override {
    CheckAlongside(depth_, "depth image", reference);
    std::vector<RegionMap> maps;
    for (size_t t = 0; t < depth_.images.size(); ++t) {
      const Image& depth = depth_.images[t];
      const PixelCloud cloud = BackProject(depth, options_);
      // RANSAC needs 3 points for a plane; fewer means the frame has (almost) no depth.
      Check(cloud.pixel.size() >= 3, "depth image has fewer than 3 valid (non-zero) pixels",
            {.file = depth_.sources[t]});
      const pcl::PointIndices plane = TablePlane(cloud, options_);
      Check(!plane.indices.empty(), "no table plane found in the depth image",
            {.file = depth_.sources[t]});
      maps.push_back(
          AssignRegions(depth, cloud, plane, ClustersOffPlane(cloud, plane, options_), options_));
    }
    return maps;
  }

 private:
  Frames depth_;
  DepthMaskOptions options_;
};

}  // namespace

std::unique_ptr<MaskSource> MakeDepthMaskSource(Frames depth, const DepthMaskOptions& options) {
  return std::make_unique<DepthMaskSource>(std::move(depth), options);
}

}  // namespace wm::metrics::seg

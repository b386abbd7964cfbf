// The motion and depth mask sources against the tabletop generator's ground-truth segmentation:
// arm IoU over whole episodes of the demo data (wm-gen-tabletop --seed 0, size 128, val split),
// rendered here with the tabletop library exactly as the generator stores them (RGB through JPEG
// quality 95, depth in millimetres, labels mapped by configs/segmentation/tabletop.yaml).
// WM_SEG_IOU_EPISODES=16 measures the whole val split (the numbers in
// docs/metrics-segmentation.md); the default, 4 (one per policy), keeps the test at seconds.
#include <gtest/gtest.h>

#include <cstdlib>
#include <iostream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ingest/tabletop/episode.h"
#include "ingest/tabletop/render.h"
#include "ingest/tabletop/tabletop_writer.h"
#include "metrics/segmentation/mask_source.h"
#include "metrics/segmentation/seg_config.h"
#include "tests/core/test_util.h"

namespace wm::metrics::seg {
namespace {

constexpr int kSize = 128;     // wm-gen-tabletop's default, the demo data's size
constexpr int kMaxSteps = 40;  // its default step limit

struct RenderedEpisode {
  Frames rgb, depth, labels;
};

Image JpegRoundTrip(const std::vector<uint8_t>& rgb) {
  cv::Mat bgr;
  cv::cvtColor(cv::Mat(kSize, kSize, CV_8UC3, const_cast<uint8_t*>(rgb.data())), bgr,
               cv::COLOR_RGB2BGR);
  std::vector<uint8_t> jpeg;
  cv::imencode(".jpg", bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, 95});
  cv::cvtColor(cv::imdecode(jpeg, cv::IMREAD_COLOR), bgr, cv::COLOR_BGR2RGB);
  return Image::FromUint8(bgr.data, kSize, kSize, 3);
}

template <class T>
Image SingleChannel(const std::vector<T>& values, double data_range) {
  std::vector<double> pixels(values.begin(), values.end());
  return Image::FromDouble(pixels.data(), kSize, kSize, 1, data_range);
}

RenderedEpisode RenderDemoEpisode(int index) {
  tabletop::TabletopOptions demo;  // the defaults are the demo data's options
  const tabletop::Rollout rollout = tabletop::RollOut(
      tabletop::EpisodeSeed(demo.seed, "val", index), demo.PolicyForEpisode(index), kMaxSteps);
  RenderedEpisode out;
  for (size_t t = 0; t < rollout.steps.size(); ++t) {
    const tabletop::Frame f = tabletop::RenderFrame({rollout.steps[t].state, rollout.look}, kSize);
    const std::string name = "val/" + std::to_string(index) + "/" + std::to_string(t);
    out.rgb.images.push_back(JpegRoundTrip(f.rgb));
    out.rgb.sources.push_back(name + ".jpg");
    out.depth.images.push_back(SingleChannel(f.depth_mm, 65535));
    out.depth.sources.push_back(name + ".depth.png");
    out.labels.images.push_back(SingleChannel(f.labels, 255));
    out.labels.sources.push_back(name + ".seg.png");
  }
  return out;
}

DepthMaskOptions DepthOptions(const SegConfig& config) {
  DepthMaskOptions o = config.depth;
  const tabletop::CameraIntrinsics k = tabletop::IntrinsicsForSize(kSize);
  o.intrinsics = CameraIntrinsics{k.fx, k.fy, k.cx, k.cy};
  return o;
}

// The demo episodes and their true region maps, rendered once per test process (ctest runs each
// test in its own process, so each test renders them once).
struct DemoEpisodes {
  SegConfig config;
  std::vector<RenderedEpisode> episodes;
  std::vector<RegionMap> truth;
};

const DemoEpisodes& Demo() {
  static const DemoEpisodes* demo = [] {
    auto* d = new DemoEpisodes;
    d->config = LoadSegConfig(test::SourceDir() + "/configs/segmentation/tabletop.yaml");
    const char* env = std::getenv("WM_SEG_IOU_EPISODES");
    for (int i = 0, n = env ? std::atoi(env) : 4; i < n; ++i) {
      d->episodes.push_back(RenderDemoEpisode(i));
      const RenderedEpisode& e = d->episodes.back();
      for (RegionMap& m : MakeFileMaskSource(e.labels, d->config.labels)->Masks(e.rgb)) {
        d->truth.push_back(std::move(m));
      }
    }
    return d;
  }();
  return *demo;
}

// Every episode's maps from `source`, and their pooled IoU per region, printed for the docs.
template <class MakeSource>
std::vector<RegionMap> MasksOfAll(const std::string& method, MakeSource make_source) {
  std::vector<RegionMap> maps;
  for (const RenderedEpisode& e : Demo().episodes) {
    for (RegionMap& m : make_source(e)->Masks(e.rgb)) maps.push_back(std::move(m));
  }
  std::cout << method << ": " << Demo().episodes.size() << " episodes, " << maps.size()
            << " frames, pooled IoU";
  for (Region r : kRegions) {
    const auto iou = RegionIoU(maps, Demo().truth, r);
    std::cout << "  " << RegionName(r) << " " << (iou ? std::to_string(*iou) : "n/a");
  }
  std::cout << "\n";
  return maps;
}

TEST(TabletopMaskIoU, DepthFindsArmBlockAndTable) {
  const std::vector<RegionMap> maps = MasksOfAll("depth", [](const RenderedEpisode& e) {
    return MakeDepthMaskSource(e.depth, DepthOptions(Demo().config));
  });
  EXPECT_GE(RegionIoU(maps, Demo().truth, Region::kArm).value(), 0.8);
  EXPECT_GE(RegionIoU(maps, Demo().truth, Region::kObject).value(), 0.6);
  EXPECT_GE(RegionIoU(maps, Demo().truth, Region::kBackground).value(), 0.95);
}

// Motion cannot tell a resting object from the table, so it never claims the object region.
TEST(TabletopMaskIoU, MotionFindsArmAndTable) {
  const std::vector<RegionMap> maps = MasksOfAll(
      "motion", [](const RenderedEpisode&) { return MakeMotionMaskSource(Demo().config.motion); });
  EXPECT_GE(RegionIoU(maps, Demo().truth, Region::kArm).value(), 0.6);
  EXPECT_GE(RegionIoU(maps, Demo().truth, Region::kBackground).value(), 0.9);
  for (const RegionMap& map : maps) EXPECT_EQ(map.Count(Region::kObject), 0);
}

}  // namespace
}  // namespace wm::metrics::seg

// Segmented-region MSE on hand-computed cases (per-frame averaging, missing regions), region
// IoU, the label-file source, the config parser and the errors each part raises.
#include "metrics/segmentation/segmented_mse.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "metrics/segmentation/mask_source.h"
#include "metrics/segmentation/seg_config.h"
#include "tests/core/test_util.h"

namespace wm::metrics::seg {
namespace {

using test::ErrorText;
constexpr Region A = Region::kArm, O = Region::kObject, B = Region::kBackground, N = Region::kNone;

Image Grey(std::vector<double> values, int h, int w) {
  return Image::FromDouble(values.data(), h, w, 1, 255);
}

RegionMap Map(std::vector<Region> pixels, int h, int w) {
  RegionMap m(h, w);
  m.pixels = std::move(pixels);
  return m;
}

Frames Named(std::vector<Image> images, const std::string& prefix) {
  Frames f;
  for (size_t i = 0; i < images.size(); ++i) f.sources.push_back(prefix + std::to_string(i));
  f.images = std::move(images);
  return f;
}

TEST(FrameMse, RestrictsToEachRegionAndAveragesChannels) {
  // 1x3 RGB: errors per pixel (summed over channels) 3*1, 3*4, 3*9.
  std::vector<double> a(9, 10), b = {11, 11, 11, 12, 12, 12, 13, 13, 13};
  const Image ref = Image::FromDouble(a.data(), 1, 3, 3, 255);
  const Image pred = Image::FromDouble(b.data(), 1, 3, 3, 255);
  const FrameSegmentedMse f = FrameMse(ref, pred, Map({A, A, N}, 1, 3));
  EXPECT_DOUBLE_EQ(f.mse, (1 + 4 + 9) / 3.0);
  EXPECT_DOUBLE_EQ(*f.regions[RegionSlot(A)].mse, (1 + 4) / 2.0);
  EXPECT_EQ(f.regions[RegionSlot(A)].pixels, 2);
  EXPECT_FALSE(f.regions[RegionSlot(O)].mse.has_value());  // empty is missing, not 0
  EXPECT_FALSE(f.regions[RegionSlot(B)].mse.has_value());
}

// WPE eq. 3: the mean of per-frame MSEs, not the MSE of all region pixels pooled.
TEST(VideoMse, AveragesPerFrameOverFramesWhereTheRegionIsPresent) {
  const std::vector<Image> ref = {Grey({0, 0, 0, 0}, 2, 2), Grey({0, 0, 0, 0}, 2, 2),
                                  Grey({0, 0, 0, 0}, 2, 2)};
  const std::vector<Image> pred = {Grey({2, 0, 0, 0}, 2, 2), Grey({0, 0, 0, 0}, 2, 2),
                                   Grey({0, 0, 0, 6}, 2, 2)};
  const std::vector<RegionMap> maps = {Map({A, B, B, B}, 2, 2), Map({A, A, A, B}, 2, 2),
                                       Map({B, B, B, B}, 2, 2)};
  const SegmentedMse r = VideoMse(ref, pred, maps);
  EXPECT_DOUBLE_EQ(*r.region_mse[RegionSlot(A)], (4.0 + 0.0) / 2);  // pooled would be 1
  EXPECT_EQ(r.region_frames[RegionSlot(A)], 2);
  EXPECT_DOUBLE_EQ(*r.region_mse[RegionSlot(B)], (0.0 + 0.0 + 36.0 / 4) / 3);
  EXPECT_FALSE(r.region_mse[RegionSlot(O)].has_value());
  EXPECT_DOUBLE_EQ(r.mse, (1.0 + 0.0 + 9.0) / 3);
  EXPECT_EQ(r.data_range, 255);

  const nlohmann::json j = ToJson(r, nullptr);
  EXPECT_TRUE(j.at("mse_object").is_null());
  EXPECT_EQ(j.at("frames_object"), 0);
  EXPECT_EQ(j.at("mse_arm"), 2.0);
  EXPECT_FALSE(j.contains("per_frame"));
  const std::vector<std::string> names = {"a", "b", "c"};
  const nlohmann::json rows = ToJson(r, &names).at("per_frame");
  EXPECT_TRUE(rows[2].at("mse_arm").is_null());
  EXPECT_EQ(rows[1].at("pixels_arm"), 3);
}

TEST(VideoMse, MismatchesNameTheFrame) {
  const std::vector<Image> two = {Grey({0, 0, 0, 0}, 2, 2), Grey({0, 0, 0, 0}, 2, 2)};
  const std::vector<RegionMap> maps = {Map({A, A, A, A}, 2, 2), Map({A, A}, 1, 2)};
  EXPECT_NE(ErrorText([&] { VideoMse(two, two, maps); }).find("frame 1"), std::string::npos);
  EXPECT_NE(ErrorText([&] { VideoMse(two, two, {maps[0]}); }).find("1 region maps"),
            std::string::npos);
}

TEST(RegionIoU, PoolsOverFramesAndIsEmptyWithoutTheRegion) {
  const std::vector<RegionMap> truth = {Map({A, A, B, B}, 2, 2), Map({A, B, B, B}, 2, 2)};
  const std::vector<RegionMap> pred = {Map({A, B, B, B}, 2, 2), Map({A, A, B, B}, 2, 2)};
  EXPECT_DOUBLE_EQ(*RegionIoU(pred, truth, A), 2.0 / 4);
  EXPECT_FALSE(RegionIoU(pred, truth, O).has_value());
}

TEST(FileMaskSource, MapsLabelsAndNamesBadFiles) {
  LabelMap labels = ParseLabelList("0=background,1=arm,2=object,3=background");
  const Frames ref = Named({Grey({0, 0, 0, 0}, 2, 2)}, "ref/");
  const Frames good = Named({Grey({0, 1, 2, 3}, 2, 2)}, "seg/");
  EXPECT_EQ(MakeFileMaskSource(good, labels)->Masks(ref)[0].pixels, (std::vector{B, A, O, B}));

  const Frames unknown = Named({Grey({0, 1, 7, 3}, 2, 2)}, "seg/");
  const std::string e = ErrorText([&] { MakeFileMaskSource(unknown, labels)->Masks(ref); });
  EXPECT_NE(e.find("seg/0"), std::string::npos) << e;
  EXPECT_NE(e.find("label 7"), std::string::npos) << e;
  labels.unlisted = Region::kNone;
  EXPECT_EQ(MakeFileMaskSource(unknown, labels)->Masks(ref)[0].pixels[2], N);

  const Frames small = Named({Grey({0, 1}, 1, 2)}, "seg/");
  EXPECT_NE(ErrorText([&] { MakeFileMaskSource(small, labels)->Masks(ref); }).find("2x2"),
            std::string::npos);
  std::vector<double> rgb(12, 0);
  const Frames colour = Named({Image::FromDouble(rgb.data(), 2, 2, 3, 255)}, "seg/");
  EXPECT_NE(
      ErrorText([&] { MakeFileMaskSource(colour, labels)->Masks(ref); }).find("single-channel"),
      std::string::npos);
  const Frames two = Named({Grey({0, 0, 0, 0}, 2, 2), Grey({0, 0, 0, 0}, 2, 2)}, "seg/");
  EXPECT_NE(ErrorText([&] { MakeFileMaskSource(two, labels)->Masks(ref); }).find("found 2"),
            std::string::npos);
}

TEST(MaskSources, RefuseWhatTheyCannotWorkWith) {
  const Frames ref = Named({Grey({0, 0, 0, 0}, 2, 2), Grey({0, 0, 0, 0}, 2, 2)}, "ref/");
  EXPECT_NE(ErrorText([&] { MakeMotionMaskSource({})->Masks(ref); }).find("at least 3"),
            std::string::npos);
  EXPECT_NE(ErrorText([&] { MakeDepthMaskSource(ref, {}); }).find("--intrinsics"),
            std::string::npos);
  DepthMaskOptions o;
  o.intrinsics = CameraIntrinsics{100, 100, 1, 1};
  const Frames no_depth = Named({Grey({0, 0, 0, 0}, 2, 2), Grey({0, 0, 0, 0}, 2, 2)}, "d/");
  EXPECT_NE(ErrorText([&] { MakeDepthMaskSource(no_depth, o)->Masks(ref); }).find("d/0"),
            std::string::npos);
}

TEST(SegConfig, ReadsTheShippedTabletopConfig) {
  const SegConfig c = LoadSegConfig(test::SourceDir() + "/configs/segmentation/tabletop.yaml");
  EXPECT_EQ(c.labels.Lookup(1), A);
  EXPECT_EQ(c.labels.Lookup(2), O);
  EXPECT_EQ(c.labels.Lookup(3), B);
  EXPECT_NE(ErrorText([&] { c.labels.Lookup(4); }).find("label 4"), std::string::npos);
  EXPECT_TRUE(c.motion.arm_borders.top);
  EXPECT_FALSE(c.depth.intrinsics.has_value());
}

TEST(SegConfig, ErrorsNameTheFileAndKey) {
  auto error = [](const std::string& yaml) {
    return ErrorText([&] { ParseSegConfig(yaml, "c.yaml"); });
  };
  EXPECT_NE(error("motoin: {}").find("key 'motoin'"), std::string::npos);
  EXPECT_NE(error("motion: {threshold: 1}").find("motion.threshold"), std::string::npos);
  EXPECT_NE(error("depth: {plane_distance: -1}").find("depth.plane_distance"), std::string::npos);
  EXPECT_NE(error("labels: {1: hand}").find("unknown region 'hand'"), std::string::npos);
  EXPECT_NE(error("depth: {intrinsics: [1, 2]}").find("c.yaml"), std::string::npos);
  EXPECT_NE(error("arm_borders: middle").find("middle"), std::string::npos);
  EXPECT_NE(error("motion: {shadows: maybe}").find("a boolean"), std::string::npos);
  const SegConfig c = ParseSegConfig(
      "arm_borders: top,left\nunlisted: none\ndepth: {intrinsics: [10, 11, 2, 3]}", "c.yaml");
  EXPECT_TRUE(c.depth.arm_borders.left);
  EXPECT_EQ(c.depth.intrinsics->fy, 11);
  EXPECT_EQ(c.labels.Lookup(9), N);
}

TEST(Flags, ParseOrExplain) {
  EXPECT_NE(ErrorText([] { ParseLabelList("0:arm"); }).find("label=region"), std::string::npos);
  EXPECT_NE(ErrorText([] { CameraIntrinsics::Parse("1,2,3"); }).find("fx,fy,cx,cy"),
            std::string::npos);
  EXPECT_NE(ErrorText([] { CameraIntrinsics::Parse("0,2,3,4"); }).find("positive"),
            std::string::npos);
  EXPECT_EQ(CameraIntrinsics::Parse("1.5, 2,3,4").fx, 1.5);
  EXPECT_EQ(ArmBorders::Parse("bottom,right").ToString(), "bottom,right");
}

}  // namespace
}  // namespace wm::metrics::seg

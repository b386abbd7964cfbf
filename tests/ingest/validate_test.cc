// Episode checks before writing: lengths, finite numbers, decodable images of the declared shape.
#include "ingest/validate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgcodecs.hpp>

#include "core/error.h"
#include "tests/core/test_util.h"

namespace wm::ingest {
namespace {

std::string Png(int h, int w) {
  std::vector<uchar> out;
  cv::imencode(".png", cv::Mat(h, w, CV_8UC3, cv::Scalar(10, 20, 30)), out);
  return {out.begin(), out.end()};
}

Episode GoodEpisode() {
  Episode e = test::MakeEpisode(3, 1);
  EncodedFrames& f = e.images["image"];
  f = EncodedFrames{};
  for (int t = 0; t < 3; ++t) f.frames.push_back(Png(6, 8));
  return e;
}

std::string ErrorOf(Episode e) {
  return test::ErrorText([&] { ValidateEpisode(e, /*full_image_check=*/true); });
}

TEST(Validate, AcceptsAGoodEpisodeAndFillsTheShape) {
  Episode e = GoodEpisode();
  ValidateEpisode(e, true);
  const EncodedFrames& f = e.images.at("image");
  EXPECT_EQ(f.encoding, "png");
  EXPECT_EQ(f.height, 6);
  EXPECT_EQ(f.width, 8);
  EXPECT_EQ(f.channels, 3);
}

TEST(Validate, NonFiniteActionNamesKeyStepAndDimension) {
  Episode e = GoodEpisode();
  e.actions[2 * kActionDim + 4] = NAN;
  std::string msg = ErrorOf(e);
  EXPECT_NE(msg.find("key 'action'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("step 2, dimension 4"), std::string::npos) << msg;
  e = GoodEpisode();
  e.rewards[1] = INFINITY;
  EXPECT_NE(ErrorOf(e).find("key 'reward'"), std::string::npos);
}

TEST(Validate, UndecodableImageNamesStreamAndStep) {
  Episode e = GoodEpisode();
  std::string& frame = e.images["image"].frames[1];
  frame = frame.substr(0, 40);  // PNG magic intact, data cut off
  std::string msg = ErrorOf(e);
  EXPECT_NE(msg.find("key 'image'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("do not decode"), std::string::npos) << msg;
  EXPECT_NE(msg.find("step 1"), std::string::npos) << msg;
  // With header-only checks the cut frame passes (that mode trades safety for speed).
  Episode quick = e;
  EXPECT_NO_THROW(ValidateEpisode(quick, /*full_image_check=*/false));
}

TEST(Validate, ShapeOtherThanDeclaredOrChangingIsAnError) {
  Episode e = GoodEpisode();
  e.images["image"].frames[2] = Png(6, 9);
  EXPECT_NE(ErrorOf(e).find("expected 6x8x3"), std::string::npos) << ErrorOf(e);
  e = GoodEpisode();
  EncodedFrames& f = e.images["image"];
  f.height = 256, f.width = 320, f.channels = 3, f.dtype = "uint8";  // as features.json declared
  std::string msg = ErrorOf(e);
  EXPECT_NE(msg.find("frame is 6x8x3 uint8, expected 256x320x3 uint8"), std::string::npos) << msg;
}

TEST(Validate, LengthMismatchNamesTheKey) {
  Episode e = GoodEpisode();
  e.is_terminal.pop_back();
  EXPECT_NE(ErrorOf(e).find("key 'is_terminal'"), std::string::npos);
  e = GoodEpisode();
  e.images["image"].frames.pop_back();
  EXPECT_NE(ErrorOf(e).find("has 2 values, expected 3"), std::string::npos) << ErrorOf(e);
}

}  // namespace
}  // namespace wm::ingest

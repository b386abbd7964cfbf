// Loading frames for the metrics: channel order, bit depths, folders, videos, and errors that
// name the file.
#include "metrics/image_io.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "core/error.h"
#include "core/image_codec.h"
#include "tests/core/test_util.h"

namespace wm::metrics {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

std::string ErrorOf(const std::function<void()>& fn) { return test::ErrorText(fn); }

void WritePng(const std::string& path, int h, int w, cv::Scalar bgr = {10, 20, 30}) {
  ASSERT_TRUE(cv::imwrite(path, cv::Mat(h, w, CV_8UC3, bgr)));
}

TEST(ImageIo, ColourBecomesRgbGreyStaysGrey) {
  test::TempDir dir;
  WritePng(dir / "c.png", 4, 5, {10, 20, 30});  // OpenCV's BGR order
  const Image colour = LoadImage(dir / "c.png");
  EXPECT_EQ(ShapeString(colour), "4x5x3");
  EXPECT_EQ(colour.data_range, 255.0);
  EXPECT_EQ(colour.at(3, 4, 0), 30);  // R
  EXPECT_EQ(colour.at(3, 4, 2), 10);  // B

  ASSERT_TRUE(cv::imwrite(dir / "g.png", cv::Mat(3, 2, CV_8UC1, cv::Scalar(7))));
  EXPECT_EQ(ShapeString(LoadImage(dir / "g.png")), "3x2x1");

  ASSERT_TRUE(cv::imwrite(dir / "a.png", cv::Mat(3, 2, CV_8UC4, cv::Scalar(1, 2, 3, 4))));
  const Image rgba = LoadImage(dir / "a.png");
  EXPECT_EQ(ShapeString(rgba), "3x2x3");  // alpha dropped
  EXPECT_EQ(rgba.at(0, 0, 0), 3);
}

TEST(ImageIo, SixteenBitImagesUseTheirRange) {
  test::TempDir dir;
  ASSERT_TRUE(cv::imwrite(dir / "d.png", cv::Mat(2, 2, CV_16UC1, cv::Scalar(40000))));
  const Image depth = LoadImage(dir / "d.png");
  EXPECT_EQ(depth.data_range, 65535.0);
  EXPECT_EQ(depth.at(1, 1, 0), 40000);
}

TEST(ImageIo, FoldersAreSortedByNameAndSkipOtherFiles) {
  test::TempDir dir;
  for (const char* name : {"b.png", "a.png", "c.jpg"}) WritePng(dir / name, 6, 7);
  std::ofstream(dir / "notes.txt") << "not a frame";
  const Frames frames = LoadFrames(dir.path().string());
  ASSERT_EQ(frames.images.size(), 3u);
  EXPECT_THAT(frames.sources[0], HasSubstr("a.png"));
  EXPECT_THAT(frames.sources[1], HasSubstr("b.png"));
  EXPECT_THAT(frames.sources[2], HasSubstr("c.jpg"));
}

TEST(ImageIo, ErrorsNameTheFile) {
  test::TempDir dir;
  std::ofstream(dir / "broken.png") << "not a png";
  EXPECT_THAT(ErrorOf([&] { LoadImage(dir / "broken.png"); }),
              AllOf(HasSubstr("broken.png"), HasSubstr("cannot decode")));
  EXPECT_THAT(ErrorOf([&] { LoadImage(dir / "missing.png"); }), HasSubstr("missing.png"));

  std::filesystem::create_directories(dir / "empty");
  EXPECT_THAT(ErrorOf([&] { LoadFrames(dir / "empty"); }),
              AllOf(HasSubstr("empty"), HasSubstr("no image files")));

  std::filesystem::create_directories(dir / "mixed");
  WritePng(dir / "mixed/0.png", 8, 8);
  WritePng(dir / "mixed/1.png", 8, 9);
  EXPECT_THAT(ErrorOf([&] { LoadFrames(dir / "mixed"); }),
              AllOf(HasSubstr("mixed/1.png"), HasSubstr("8x8x3 vs 8x9x3")));

  std::ofstream(dir / "fake.mp4") << "not a video";
  EXPECT_THAT(ErrorOf([&] { LoadFrames(dir / "fake.mp4"); }), HasSubstr("fake.mp4"));
}

TEST(ImageIo, PairsMustMatchInCountAndShape) {
  test::TempDir dir;
  for (const char* folder : {"pred", "real", "short"}) {
    std::filesystem::create_directories(dir / folder);
  }
  for (int t = 0; t < 3; ++t) {
    WritePng(dir / ("pred/" + std::to_string(t) + ".png"), 8, 8);
    WritePng(dir / ("real/" + std::to_string(t) + ".png"), t == 2 ? 9 : 8, 8);
  }
  WritePng(dir / "short/0.png", 8, 8);
  const Frames pred = LoadFrames(dir / "pred"), shorter = LoadFrames(dir / "short");
  EXPECT_THAT(ErrorOf([&] { CheckPaired(pred, shorter); }), HasSubstr("frame counts differ: 3"));

  Frames real;
  for (int t = 0; t < 3; ++t) {
    real.sources.push_back(dir / ("real/" + std::to_string(t) + ".png"));
    real.images.push_back(LoadImage(real.sources.back()));
  }
  EXPECT_THAT(ErrorOf([&] { CheckPaired(pred, real); }),
              AllOf(HasSubstr("pred/2.png"), HasSubstr("real/2.png")));
}

// core/image_codec.h (what model-only builds decode with) against OpenCV's decoders on the same
// bytes: PNG of every colour type and depth OpenCV writes, and JPEG (both use libjpeg-turbo with
// its default integer IDCT, so the pixels are equal, not just close).
TEST(ImageCodec, DecodesExactlyAsOpenCv) {
  cv::Mat colour(21, 17, CV_8UC3), grey(9, 11, CV_8UC1), wide(6, 5, CV_16UC1), alpha(4, 3, CV_8UC4);
  cv::randu(colour, 0, 256);
  cv::randu(grey, 0, 256);
  cv::randu(wide, 0, 65536);
  cv::randu(alpha, 0, 256);
  for (const auto& [ext, mat] : std::vector<std::pair<std::string, cv::Mat>>{{".png", colour},
                                                                             {".png", grey},
                                                                             {".png", wide},
                                                                             {".png", alpha},
                                                                             {".jpg", colour},
                                                                             {".jpg", grey}}) {
    std::vector<uchar> buf;
    ASSERT_TRUE(cv::imencode(ext, mat, buf));
    const std::string bytes(buf.begin(), buf.end());
    const DecodedImage ours = DecodePngOrJpeg(bytes, "case");
    cv::Mat ref = cv::imdecode(buf, cv::IMREAD_UNCHANGED);
    if (ref.channels() == 3) cv::cvtColor(ref, ref, cv::COLOR_BGR2RGB);
    if (ref.channels() == 4) cv::cvtColor(ref, ref, cv::COLOR_BGRA2RGB);
    SCOPED_TRACE(ext + " " + std::to_string(mat.channels()) + " channels, depth " +
                 std::to_string(mat.depth()));
    EXPECT_EQ(ours.height, ref.rows);
    EXPECT_EQ(ours.width, ref.cols);
    EXPECT_EQ(ours.channels, ref.channels());
    EXPECT_EQ(ours.bit_depth, ref.depth() == CV_16U ? 16 : 8);
    ASSERT_EQ(ours.data.size(), ref.total() * ref.elemSize());
    EXPECT_EQ(std::memcmp(ours.data.data(), ref.data, ours.data.size()), 0);
  }
}

TEST(ImageIo, VideosYieldEveryFrame) {
  test::TempDir dir;
  const std::string path = dir / "clip.avi";
  cv::VideoWriter writer(path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10, cv::Size(64, 48));
  if (!writer.isOpened()) GTEST_SKIP() << "this OpenCV build cannot write MJPG/AVI";
  for (int t = 0; t < 5; ++t) writer.write(cv::Mat(48, 64, CV_8UC3, cv::Scalar(40 * t, 0, 0)));
  writer.release();
  const Frames frames = LoadFrames(path);
  ASSERT_EQ(frames.images.size(), 5u);
  EXPECT_EQ(ShapeString(frames.images[4]), "48x64x3");
  EXPECT_EQ(frames.sources[4], path + "#frame 4");
  EXPECT_NEAR(frames.images[4].at(10, 10, 2), 160, 8);  // blue survives MJPG, as channel 2
  EXPECT_TRUE(IsVideoFile("x/CLIP.MP4"));
  EXPECT_FALSE(IsVideoFile("x/frame.png"));
}

}  // namespace
}  // namespace wm::metrics

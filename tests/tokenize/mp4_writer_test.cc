// Mp4Writer (tokenize/mp4_writer.h): H.264 by default, mp4v when the H.264 encoder is missing,
// and either way the whole file under its name and no hidden temp file.
#include "tokenize/mp4_writer.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/core.hpp>

#include "ingest/video/video_decoder.h"
#include "tests/core/test_util.h"

namespace wm::tokenize {
namespace {

ingest::VideoStreamInfo WriteAndDecode(const std::string& path, const std::string& encoder) {
  Mp4Writer video(path, 4.0, 48, 32, encoder);
  for (int t = 0; t < 5; ++t) video.Write(cv::Mat(32, 48, CV_8UC3, cv::Scalar(40 * t, 90, 200)));
  video.Commit();
  return ingest::DecodeVideo(path, [](const ingest::RgbFrame&) {});
}

TEST(Mp4WriterTest, WritesH264) {
  test::TempDir dir;
  const auto info = WriteAndDecode(dir / "clip.mp4", "libx264");
  EXPECT_EQ(info.codec, "h264");
  EXPECT_EQ(info.frames, 5);
  EXPECT_EQ(info.width, 48);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 1);
}

TEST(Mp4WriterTest, FallsBackToMp4vWithoutAnH264Encoder) {
  test::TempDir dir;
  const auto info = WriteAndDecode(dir / "clip.mp4", "no-such-encoder");
  EXPECT_EQ(info.codec, "mpeg4");  // mp4v
  EXPECT_EQ(info.frames, 5);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 1);
}

}  // namespace
}  // namespace wm::tokenize

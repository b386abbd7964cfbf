// core/image_codec.h on its own (model-only builds run these too): PNG round trips, the format
// sniffer, and errors that name the source. tests/metrics/image_io_test.cc checks its decoding
// against OpenCV's, an independent reference, in full builds.
#include "core/image_codec.h"

#include <gtest/gtest.h>

#include "tests/core/test_util.h"

namespace wm {
namespace {

std::vector<uint8_t> Ramp(int h, int w, int c) {
  std::vector<uint8_t> v(static_cast<size_t>(h) * w * c);
  for (size_t i = 0; i < v.size(); ++i) v[i] = static_cast<uint8_t>(i * 7 + i / 3);
  return v;
}

TEST(ImageCodec, PngRoundTripKeepsEveryPixelAndChannelCount) {
  for (int channels : {1, 3}) {
    const std::vector<uint8_t> pixels = Ramp(5, 7, channels);
    const std::string png = EncodePng(pixels.data(), 5, 7, channels);
    EXPECT_EQ(SniffImageFormat(png), "png");
    const DecodedImage d = DecodePngOrJpeg(png, "ramp");
    EXPECT_EQ(d.height, 5);
    EXPECT_EQ(d.width, 7);
    EXPECT_EQ(d.channels, channels);
    EXPECT_EQ(d.bit_depth, 8);
    EXPECT_EQ(d.data, pixels);
  }
}

TEST(ImageCodec, SniffsByMagicBytes) {
  EXPECT_EQ(SniffImageFormat(std::string("\xff\xd8\xff\xe0", 4)), "jpeg");
  EXPECT_EQ(SniffImageFormat("GIF89a"), "");
  EXPECT_EQ(SniffImageFormat(""), "");
}

TEST(ImageCodec, DamagedOrForeignBytesAreErrorsNamingTheSource) {
  const std::vector<uint8_t> pixels = Ramp(8, 8, 3);
  const std::string png = EncodePng(pixels.data(), 8, 8, 3);
  const std::string truncated = test::ErrorText(
      [&] { DecodePngOrJpeg(png.substr(0, png.size() / 2), "shards/val#episode 3/image[5]"); });
  EXPECT_NE(truncated.find("shards/val#episode 3/image[5]"), std::string::npos) << truncated;
  EXPECT_NE(truncated.find("cannot decode PNG"), std::string::npos) << truncated;
  const std::string jpeg = test::ErrorText(
      [&] { DecodePngOrJpeg(std::string("\xff\xd8\xff\xe0garbage", 11), "x.jpg"); });
  EXPECT_NE(jpeg.find("cannot decode JPEG"), std::string::npos) << jpeg;
  EXPECT_NE(test::ErrorText([&] { DecodePngOrJpeg("GIF89a....", "y"); }).find("not a PNG or JPEG"),
            std::string::npos);
  EXPECT_NE(test::ErrorText([&] { EncodePng(pixels.data(), 8, 8, 2); }).find("1 or 3 channels"),
            std::string::npos);
}

}  // namespace
}  // namespace wm

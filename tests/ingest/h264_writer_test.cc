// The H.264 MP4 writer (ingest/video/h264_writer.h), read back with the repository's decoder:
// codec, frame count and size, pixels within codec noise, moov before mdat, the same bytes for
// the same frames, odd sizes padded, and nullptr for a missing encoder (the mp4v fallback).
#include "ingest/video/h264_writer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include "ingest/video/video_decoder.h"
#include "tests/core/test_util.h"

namespace wm::ingest {
namespace {

using Image = std::vector<uint8_t>;  // packed BGR, height x width x 3

// Frame t: a colour gradient with a bright square moving right, sharp-edged like a demo strip.
Image SyntheticFrame(int t, int width, int height) {
  Image bgr(static_cast<size_t>(width) * height * 3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      uint8_t* p = &bgr[(static_cast<size_t>(y) * width + x) * 3];
      const bool square = x >= 4 + 3 * t && x < 20 + 3 * t && y >= 8 && y < 24;
      p[0] = square ? 240 : static_cast<uint8_t>(40 + 2 * x);
      p[1] = square ? 220 : static_cast<uint8_t>(60 + 2 * y);
      p[2] = square ? 30 : 120;
    }
  }
  return bgr;
}

std::vector<Image> Clip(int frames, int width, int height) {
  std::vector<Image> clip;
  for (int t = 0; t < frames; ++t) clip.push_back(SyntheticFrame(t, width, height));
  return clip;
}

void WriteClip(const std::string& path, const std::vector<Image>& clip, int width, int height) {
  auto writer = H264Writer::Open(path, {.fps = 4, .width = width, .height = height});
  ASSERT_NE(writer, nullptr) << "this FFmpeg has no libx264";
  for (const Image& frame : clip) writer->Write(frame.data(), static_cast<size_t>(width) * 3);
  writer->Finish();
}

std::string Bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

// The 4-character types of the file's top-level ISO BMFF boxes, in order.
std::vector<std::string> TopLevelBoxes(const std::string& bytes) {
  std::vector<std::string> types;
  for (size_t at = 0; at + 8 <= bytes.size();) {
    auto u8 = [&](size_t i) { return static_cast<uint64_t>(static_cast<uint8_t>(bytes[i])); };
    uint64_t size = u8(at) << 24 | u8(at + 1) << 16 | u8(at + 2) << 8 | u8(at + 3);
    if (size == 1) {  // 64-bit size after the type
      size = 0;
      for (int i = 0; i < 8; ++i) size = size << 8 | u8(at + 8 + i);
    }
    types.push_back(bytes.substr(at + 4, 4));
    if (size < 8) break;
    at += size;
  }
  return types;
}

// Mean |decoded - original| over the original's pixels (RGB vs BGR handled), per frame.
double MeanAbsError(const RgbFrame& got, const Image& want, int width, int height) {
  double sum = 0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      for (int c = 0; c < 3; ++c) {
        sum += std::abs(got.pixels[(static_cast<size_t>(y) * got.width + x) * 3 + c] -
                        want[(static_cast<size_t>(y) * width + x) * 3 + (2 - c)]);
      }
    }
  }
  return sum / (3.0 * width * height);
}

TEST(H264WriterTest, DecodesBackAsH264WithinCodecNoise) {
  test::TempDir dir;
  const auto clip = Clip(8, 64, 64);
  WriteClip(dir / "clip.mp4", clip, 64, 64);
  double worst = 0;
  const VideoStreamInfo info = DecodeVideo(dir / "clip.mp4", [&](const RgbFrame& f) {
    const size_t t = static_cast<size_t>(std::lround(f.timestamp_s * 4));
    ASSERT_LT(t, clip.size());
    worst = std::max(worst, MeanAbsError(f, clip[t], 64, 64));
  });
  EXPECT_EQ(info.codec, "h264");
  EXPECT_EQ(info.frames, 8);
  EXPECT_EQ(info.width, 64);
  EXPECT_EQ(info.height, 64);
  EXPECT_LT(worst, 8.0);  // measured ~1 at crf 18; a wrong colour conversion is 30+
  std::printf("worst mean abs error %.3f levels\n", worst);
}

TEST(H264WriterTest, IndexComesBeforeMediaData) {  // faststart: browsers play while loading
  test::TempDir dir;
  WriteClip(dir / "clip.mp4", Clip(4, 64, 64), 64, 64);
  const auto boxes = TopLevelBoxes(Bytes(dir / "clip.mp4"));
  const auto moov = std::find(boxes.begin(), boxes.end(), "moov");
  const auto mdat = std::find(boxes.begin(), boxes.end(), "mdat");
  ASSERT_NE(moov, boxes.end());
  ASSERT_NE(mdat, boxes.end());
  EXPECT_LT(moov - boxes.begin(), mdat - boxes.begin());
}

TEST(H264WriterTest, SameFramesGiveSameBytes) {
  test::TempDir dir;
  const auto clip = Clip(8, 64, 64);
  WriteClip(dir / "a.mp4", clip, 64, 64);
  WriteClip(dir / "b.mp4", clip, 64, 64);
  EXPECT_FALSE(Bytes(dir / "a.mp4").empty());
  EXPECT_TRUE(Bytes(dir / "a.mp4") == Bytes(dir / "b.mp4"));  // no 100 kB dump on failure
}

// Worst per-frame mean error over the top-left width x height px of the video at `path`.
double WorstError(const std::string& path, const std::vector<Image>& clip, int width, int height,
                  VideoStreamInfo* info) {
  double worst = 0;
  *info = DecodeVideo(path, [&](const RgbFrame& f) {
    worst = std::max(worst, MeanAbsError(f, clip[std::lround(f.timestamp_s * 4)], width, height));
  });
  return worst;
}

TEST(H264WriterTest, OddSizesArePaddedToEven) {
  test::TempDir dir;
  const auto odd = Clip(3, 33, 17), even = Clip(3, 34, 18);  // same picture, one more row/column
  WriteClip(dir / "odd.mp4", odd, 33, 17);
  WriteClip(dir / "even.mp4", even, 34, 18);
  VideoStreamInfo info, even_info;
  const double odd_error = WorstError(dir / "odd.mp4", odd, 33, 17, &info);
  const double even_error = WorstError(dir / "even.mp4", even, 34, 18, &even_info);
  EXPECT_EQ(info.width, 34);
  EXPECT_EQ(info.height, 18);
  EXPECT_EQ(info.frames, 3);
  std::printf("33x17: worst mean abs error %.3f levels (34x18: %.3f)\n", odd_error, even_error);
  // Sharp colour edges on so few pixels cost chroma (~9 levels either way); a sheared or
  // channel-swapped copy is 20+.
  EXPECT_LT(odd_error, even_error + 2);
}

TEST(H264WriterTest, MissingEncoderReturnsNullAndWritesNothing) {
  test::TempDir dir;
  EXPECT_EQ(H264Writer::Open(dir / "x.mp4", {.width = 64, .height = 64, .encoder = "no-such"}),
            nullptr);
  EXPECT_FALSE(std::filesystem::exists(dir / "x.mp4"));
}

}  // namespace
}  // namespace wm::ingest

#pragma once
// H.264 (avc1) MP4 files that browsers, W&B and TensorBoard play: yuv420p, the index (moov) at
// the front of the file, one encoder thread so the same frames give the same bytes
// (docs/reports.md "Videos"). libav* stays inside h264_writer.cc.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

namespace wm::ingest {

struct H264Options {
  double fps = 4;
  int width = 0, height = 0;  // of the frames given; odd sizes are padded to even (yuv420p)
  // The libavcodec encoder. Debian's FFmpeg has libx264; tests name a missing one.
  std::string encoder = "libx264";
  // x264's constant rate factor: 18 keeps 64 px frames' edges (~1 level of mean error).
  int crf = 18;
};

class H264Writer {
 public:
  // Opens `path` for writing, or returns nullptr when this FFmpeg has no encoder named
  // `options.encoder` (the caller falls back). Throws wm::Error naming `path` on other failures.
  static std::unique_ptr<H264Writer> Open(const std::string& path, const H264Options& options);
  ~H264Writer();  // closes the file; a file not Finish()ed is incomplete
  H264Writer(const H264Writer&) = delete;
  H264Writer& operator=(const H264Writer&) = delete;

  // One frame of options.width x options.height packed BGR pixels, rows `stride` bytes apart.
  void Write(const uint8_t* bgr, size_t stride);
  // Flushes the encoder, moves the index to the front and closes the file. Throws wm::Error
  // naming the file when a write failed (disk full).
  void Finish();

 private:
  struct Impl;
  explicit H264Writer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace wm::ingest

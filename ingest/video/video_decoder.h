#pragma once
// Decodes the video stream of an MP4 (or any container FFmpeg reads) frame by frame, with each
// frame's presentation time. libav* stays inside video_decoder.cc.
#include <cstdint>
#include <functional>
#include <limits>
#include <string>

namespace wm::ingest {

struct VideoStreamInfo {
  std::string codec;    // the stream's own codec ("av1", "h264", ...), whatever metadata claims
  std::string decoder;  // the libavcodec decoder used ("libdav1d", "h264", ...)
  int width = 0, height = 0;
  int64_t frames = 0;            // frames decoded
  double last_timestamp_s = -1;  // presentation time of the last frame decoded; -1: none
};

// The part of the file wanted: frames presented in [from_s, to_s]. LeRobot v3.0 files concatenate
// episodes, so one episode's frames are a span of the file. Decoding starts at the key frame at or
// before from_s (earlier frames may still be handed over) and stops after the first frame past
// to_s.
struct DecodeRange {
  double from_s = 0;
  double to_s = std::numeric_limits<double>::infinity();
};

// One decoded frame: RGB, 8 bits per channel, rows packed (height x width x 3 bytes).
struct RgbFrame {
  double timestamp_s = 0;  // presentation time: pts x the stream's time base
  const uint8_t* pixels = nullptr;
  int height = 0, width = 0;
};

// Decodes every frame of the file's best video stream in presentation order and hands each to
// `on_frame`. Single-threaded decoding, so the pixels never depend on thread timing. Throws
// wm::Error naming the file (and the frame) when the container or a packet does not decode.
VideoStreamInfo DecodeVideo(const std::string& path,
                            const std::function<void(const RgbFrame&)>& on_frame,
                            const DecodeRange& range = {});

}  // namespace wm::ingest

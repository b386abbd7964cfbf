#pragma once
// Loading frames for the metrics: one image file, a folder of frames, or a video file (OpenCV's
// decoders; in WM_MODEL_ONLY builds PNG and JPEG only, through libpng/libjpeg, and no video:
// metrics/image_decoder.h). Colour images come out as RGB.
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "metrics/image.h"

namespace wm::metrics {

// Thrown by the light decoder (wm_metrics_light, behind the light wm-metrics) for input it cannot
// decode exactly as OpenCV would: a video, a format other than PNG or JPEG, a PNG whose channels
// OpenCV counts differently, or a file that fails to read or decode. The light wm-metrics then
// hands the whole command to wm-metrics-full (docs/metrics.md, "Two programs"). Not a wm::Error,
// so that no stage's error handling rewords or reports it.
class NeedsFullDecoder : public std::runtime_error {
 public:
  explicit NeedsFullDecoder(const std::string& source)
      : std::runtime_error(source + ": needs OpenCV's decoder (wm-metrics-full)") {}
};

// One image file (PNG, JPEG, BMP, TIFF, ... as OpenCV reads them): grey stays 1 channel, colour
// becomes RGB, an alpha channel is dropped. 8-bit -> data_range 255, 16-bit -> 65535, float ->
// 1.0. Throws wm::Error naming the file when it cannot be read.
Image LoadImage(const std::string& path);

// An encoded image held in memory (a shard's JPEG/PNG bytes), decoded as LoadImage decodes a
// file; `source` names it in errors ("shards/val#episode 3/segmentation[5]").
Image DecodeImage(const std::string& bytes, const std::string& source);

// Image files in a folder (by extension, not recursive), sorted by file name. Throws wm::Error
// naming the folder when it cannot be listed or holds no image.
std::vector<std::string> ListImageFiles(const std::string& folder);

// Whether `path` names a video by its extension (.mp4, .avi, .mov, .mkv, .webm, .m4v, .mpg,
// .mpeg, .wmv, .flv, .gif).
bool IsVideoFile(const std::string& path);

// A sequence of frames and where each came from ("dir/0001.png", "clip.mp4#frame 7").
struct Frames {
  std::vector<Image> images;
  std::vector<std::string> sources;
};

// The frames of a folder (its images sorted by name), a video file (every frame, RGB,
// data_range 255) or a single image (one frame), read one at a time so long inputs stream in
// bounded memory. Throws wm::Error naming the file when one is unreadable, a folder is empty,
// or a frame's shape differs from the first frame's.
class FrameStream {
 public:
  explicit FrameStream(const std::string& path);
  ~FrameStream();
  FrameStream(const FrameStream&) = delete;
  FrameStream& operator=(const FrameStream&) = delete;
  // Up to `max_frames` next frames appended to `out`; how many were read (0 at the end).
  size_t Read(size_t max_frames, Frames* out);
  const std::string& path() const;

 private:
  struct State;
  std::unique_ptr<State> s_;
};

// Every frame of FrameStream(path) at once.
Frames LoadFrames(const std::string& path);

// Throws wm::Error naming the first pair of sources whose shapes or data ranges differ, or both
// inputs' frame counts when they differ.
void CheckPaired(const Frames& a, const Frames& b);

}  // namespace wm::metrics

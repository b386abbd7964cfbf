#pragma once
// The pixel decoders behind image_io.cc. Full builds use OpenCV's (every format it reads, and
// videos: image_decoder_opencv.cc); WM_MODEL_ONLY builds, which have no OpenCV, use
// core/image_codec.h (PNG and JPEG, no video: image_decoder_png.cc). Internal to wm_metrics.
#include <memory>
#include <string>

#include "metrics/image.h"

namespace wm::metrics::internal {

// Encoded image bytes / an image file as an Image (grey stays grey, colour becomes RGB, alpha is
// dropped). Throws wm::Error naming `source` / `path`.
Image DecodeImageBytes(const std::string& bytes, const std::string& source);
Image ReadImageFile(const std::string& path);

// The frames of a video file, in order.
class VideoDecoder {
 public:
  // Throws wm::Error naming `path` when it cannot be opened.
  explicit VideoDecoder(const std::string& path);
  ~VideoDecoder();
  VideoDecoder(const VideoDecoder&) = delete;
  VideoDecoder& operator=(const VideoDecoder&) = delete;
  // The next frame into `out`; false at the end. `source` names it in errors.
  bool Next(const std::string& source, Image* out);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace wm::metrics::internal

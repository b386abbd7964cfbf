#pragma once
// The pixel decoders behind image_io.cc. Full builds use OpenCV's (every format it reads, and
// videos: image_decoder_opencv.cc); WM_MODEL_ONLY builds, which have no OpenCV, use
// core/image_codec.h (PNG and JPEG, no video: image_decoder_png.cc); the light wm-metrics uses
// core/image_codec.h where its pixels are exactly OpenCV's and throws NeedsFullDecoder elsewhere
// (image_decoder_light.cc). Internal to wm_metrics and wm_metrics_light.
#include <memory>
#include <string>

#include "metrics/image.h"

namespace wm {
struct DecodedImage;
}

namespace wm::metrics::internal {

// core/image_codec.h's pixels as an Image: 8-bit -> data_range 255, 16-bit -> 65535.
Image FromDecodedImage(const DecodedImage& decoded);

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

#pragma once
// Encoded-image checks and transforms for ingest (OpenCV stays inside image_codec.cc).
#include <string>

#include "core/episode.h"

namespace wm::ingest {

struct ImageInfo {
  int height = 0, width = 0, channels = 0;
  std::string dtype;  // "uint8" or "uint16"
};

// Decodes fully (proves the bytes are a valid image) and returns its shape. Throws wm::Error
// when the bytes do not decode.
ImageInfo DecodeInfo(const std::string& encoded);
// "jpeg" or "png" from the magic bytes; "" when neither.
std::string SniffEncoding(const std::string& encoded);

// Checks every frame decodes (`full`) or has a valid header magic only (`!full`), that all
// frames share one shape, and fills height/width/channels/dtype. A shape already set (declared
// by the source, e.g. TFDS features.json) must match. Errors name the step.
void CheckFrames(EncodedFrames& frames, bool full);

// Re-encodes every frame at width x height: INTER_AREA for colour, INTER_NEAREST for label or
// depth streams (`nearest`), same encoding (JPEG quality 95 / PNG).
void ResizeFrames(EncodedFrames& frames, int width, int height, bool nearest);

// Encodes raw pixels (HxWxC, uint8, RGB order) as "png" or "jpeg" (quality 95, as --resize);
// used by sources that hold raw arrays (HDF5: PNG) or decoded video frames (LeRobot: JPEG).
std::string EncodeRgb(const uint8_t* pixels, int height, int width, int channels,
                      const std::string& encoding);
inline std::string EncodePngRgb(const uint8_t* pixels, int height, int width, int channels) {
  return EncodeRgb(pixels, height, width, channels, "png");
}

}  // namespace wm::ingest

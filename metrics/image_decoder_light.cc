// The light wm-metrics' decoder (wm_metrics_light): PNG and JPEG through core/image_codec.h, which
// loads in a millisecond where OpenCV's imgcodecs and videoio load some 240 shared libraries
// (about 0.2 s a process). It decodes only what it decodes to exactly OpenCV's pixels and channel
// count; for anything else it throws NeedsFullDecoder and wm-metrics-full, with OpenCV, runs the
// command instead, so results and error messages are OpenCV's in every case.
#include <string_view>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image_codec.h"
#include "metrics/image_decoder.h"
#include "metrics/image_io.h"

namespace wm::metrics::internal {
namespace {

// JPEG, and PNG of grey, RGB or RGBA at 8 or 16 bits with no tRNS chunk: the cases
// tests/metrics/image_io_test.cc (DecodesExactlyAsOpenCv) and
// tests/metrics/test_wm_metrics_light.py pin to OpenCV's pixels. OpenCV reads grey+alpha (and grey
// with tRNS) as four channels, which become RGB, where core/image_codec.h keeps one; palette and
// 1-4 bit PNGs are left to OpenCV too.
bool DecodesAsOpenCv(std::string_view bytes) {
  const std::string format = SniffImageFormat(bytes);
  if (format == "jpeg") return true;
  constexpr size_t kBitDepthAt = 24, kColourTypeAt = 25;  // in IHDR, the first chunk
  if (format != "png" || bytes.size() <= kColourTypeAt) return false;
  const auto depth = static_cast<unsigned char>(bytes[kBitDepthAt]);
  const auto colour = static_cast<unsigned char>(bytes[kColourTypeAt]);
  const bool grey_rgb_or_rgba = colour == 0 || colour == 2 || colour == 6;
  const size_t transparency = bytes.find("tRNS"), pixels = bytes.find("IDAT");
  return grey_rgb_or_rgba && (depth == 8 || depth == 16) &&
         (transparency == std::string_view::npos || transparency > pixels);
}

Image DecodeOrHandOver(const std::string& bytes, const std::string& source) {
  try {
    if (DecodesAsOpenCv(bytes)) return FromDecodedImage(DecodePngOrJpeg(bytes, source));
  } catch (const Error&) {
    // damaged bytes: wm-metrics-full reports them in OpenCV's words
  }
  throw NeedsFullDecoder(source);
}

}  // namespace

Image DecodeImageBytes(const std::string& bytes, const std::string& source) {
  return DecodeOrHandOver(bytes, source);
}

Image ReadImageFile(const std::string& path) {
  std::string bytes;
  try {
    bytes = ReadFile(path);
  } catch (const Error&) {
    throw NeedsFullDecoder(path);  // unreadable: wm-metrics-full reports it as OpenCV does
  }
  return DecodeOrHandOver(bytes, path);
}

struct VideoDecoder::Impl {};

VideoDecoder::VideoDecoder(const std::string& path) { throw NeedsFullDecoder(path); }

VideoDecoder::~VideoDecoder() = default;

bool VideoDecoder::Next(const std::string&, Image*) { return false; }

}  // namespace wm::metrics::internal

// libpng/libjpeg behind image_io.cc in WM_MODEL_ONLY builds, which have no OpenCV: PNG and JPEG
// images only, no video (docs/gpu.md).

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image_codec.h"
#include "metrics/image_decoder.h"

namespace wm::metrics::internal {
namespace {

const char kNoOpenCv[] = "this wmkit build has no OpenCV (WM_MODEL_ONLY)";

}  // namespace

Image DecodeImageBytes(const std::string& bytes, const std::string& source) {
  return FromDecodedImage(DecodePngOrJpeg(bytes, source));
}

Image ReadImageFile(const std::string& path) {
  const std::string bytes = ReadFile(path);
  Check(!SniffImageFormat(bytes).empty(),
        std::string("cannot decode image: only PNG and JPEG can be read, as ") + kNoOpenCv,
        {.file = path});
  return DecodeImageBytes(bytes, path);
}

struct VideoDecoder::Impl {};

VideoDecoder::VideoDecoder(const std::string& path) {
  throw Error(std::string("cannot read videos: ") + kNoOpenCv, {.file = path});
}

VideoDecoder::~VideoDecoder() = default;

bool VideoDecoder::Next(const std::string&, Image*) { return false; }

}  // namespace wm::metrics::internal

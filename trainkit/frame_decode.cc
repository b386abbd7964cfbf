#include "trainkit/frame_decode.h"

#include <algorithm>
#include <cmath>
#include <vector>

#ifdef WM_HAVE_OPENCV
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#endif

#include "core/error.h"
#include "core/image_codec.h"

namespace wm::trainkit {
namespace {

// [height, width, 3] RGB at exactly size x size -> planar floats in [-1, 1].
void SquareRgb8ToPlanar(const uint8_t* rgb, int size, float* out) {
  const size_t plane = static_cast<size_t>(size) * size;
  for (size_t p = 0; p < plane; ++p) {
    for (int c = 0; c < 3; ++c) out[c * plane + p] = rgb[3 * p + c] / 127.5f - 1.f;
  }
}

}  // namespace

#ifdef WM_HAVE_OPENCV
void DecodeFrame(const std::string& encoded, int size, float* out) {
  cv::Mat buf(1, static_cast<int>(encoded.size()), CV_8UC1, const_cast<char*>(encoded.data()));
  cv::Mat bgr = cv::imdecode(buf, cv::IMREAD_COLOR);
  Check(!bgr.empty(), "cannot decode frame (" + std::to_string(encoded.size()) + " bytes)");
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  Rgb8ToPlanar(rgb.ptr<uint8_t>(), rgb.rows, rgb.cols, size, out);
}

void Rgb8ToPlanar(const uint8_t* rgb, int height, int width, int size, float* out) {
  const cv::Mat in(height, width, CV_8UC3, const_cast<uint8_t*>(rgb));  // only read
  cv::Mat resized = in;
  if (height != size || width != size) {
    cv::resize(in, resized, cv::Size(size, size), 0, 0, cv::INTER_AREA);
  }
  SquareRgb8ToPlanar(resized.isContinuous() ? resized.ptr<uint8_t>() : resized.clone().data, size,
                     out);
}
#else
// Without OpenCV (WM_MODEL_ONLY, docs/gpu.md): libpng/libjpeg decode and the resampling below.
void DecodeFrame(const std::string& encoded, int size, float* out) {
  const DecodedImage image = DecodePngOrJpeg(encoded, "frame");
  Check(image.bit_depth == 8, "cannot decode frame: 16-bit images are not camera frames");
  std::vector<uint8_t> rgb;
  const uint8_t* pixels = image.data.data();
  if (image.channels == 1) {  // grey frames feed the colour model as equal channels
    rgb.resize(image.data.size() * 3);
    for (size_t i = 0; i < image.data.size(); ++i)
      rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = image.data[i];
    pixels = rgb.data();
  }
  Rgb8ToPlanar(pixels, image.height, image.width, size, out);
}

// Area resampling (each output pixel the mean of the input area it covers, as OpenCV's
// INTER_AREA when shrinking), rounded to uint8 like OpenCV's.
void Rgb8ToPlanar(const uint8_t* rgb, int height, int width, int size, float* out) {
  if (height == size && width == size) return SquareRgb8ToPlanar(rgb, size, out);
  std::vector<uint8_t> resized(static_cast<size_t>(size) * size * 3);
  const double sy = double(height) / size, sx = double(width) / size;
  for (int y = 0; y < size; ++y) {
    const double y0 = y * sy, y1 = (y + 1) * sy;
    for (int x = 0; x < size; ++x) {
      const double x0 = x * sx, x1 = (x + 1) * sx;
      double sum[3] = {0, 0, 0}, area = 0;
      for (int iy = int(y0); iy < std::min(height, int(std::ceil(y1))); ++iy) {
        const double wy = std::min(y1, iy + 1.0) - std::max(y0, double(iy));
        for (int ix = int(x0); ix < std::min(width, int(std::ceil(x1))); ++ix) {
          const double w = wy * (std::min(x1, ix + 1.0) - std::max(x0, double(ix)));
          for (int c = 0; c < 3; ++c) sum[c] += w * rgb[(size_t(iy) * width + ix) * 3 + c];
          area += w;
        }
      }
      for (int c = 0; c < 3; ++c)
        resized[(size_t(y) * size + x) * 3 + c] = uint8_t(std::lround(sum[c] / area));
    }
  }
  SquareRgb8ToPlanar(resized.data(), size, out);
}
#endif

}  // namespace wm::trainkit

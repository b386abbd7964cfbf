#pragma once
// wm::metrics::Image: one frame as the pixel metrics see it — HxWxC doubles plus the value range
// that PSNR's peak and SSIM's constants are taken from (docs/metrics.md, "Images").
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace wm::metrics {

struct Image {
  int height = 0;
  int width = 0;
  int channels = 0;            // 1 (grey) or 3 (colour; metrics treat the channels alike)
  std::vector<double> pixels;  // row-major HxWxC, channels interleaved: height*width*channels
  double data_range = 1.0;     // R: 255 for uint8 sources, 1.0 for float sources unless given

  // Copies an interleaved HxWxC buffer. uint8 data gets R = 255; float data gets `data_range`.
  static Image FromUint8(const uint8_t* data, int height, int width, int channels);
  static Image FromFloat(const float* data, int height, int width, int channels,
                         double data_range = 1.0);
  static Image FromDouble(const double* data, int height, int width, int channels,
                          double data_range = 1.0);

  size_t size() const { return static_cast<size_t>(height) * width * channels; }
  double at(int y, int x, int c) const {
    return pixels[(static_cast<size_t>(y) * width + x) * channels + c];
  }
};

// "HxWxC", for messages.
std::string ShapeString(const Image& image);

// Throws wm::Error unless the image is well formed: positive size, 1 or 3 channels, a pixel
// count matching the shape and a positive data range.
void CheckImage(const Image& image);

// Throws wm::Error unless `a` and `b` are well formed with the same shape and data range.
void CheckSameShape(const Image& a, const Image& b);

}  // namespace wm::metrics

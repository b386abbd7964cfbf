#include "metrics/image.h"

#include "core/error.h"

namespace wm::metrics {
namespace {

template <typename T>
Image Copy(const T* data, int height, int width, int channels, double data_range) {
  Image image;
  image.height = height;
  image.width = width;
  image.channels = channels;
  image.data_range = data_range;
  Check(height > 0 && width > 0, "image size must be positive, got " + ShapeString(image));
  image.pixels.assign(data, data + image.size());
  CheckImage(image);
  return image;
}

}  // namespace

Image Image::FromUint8(const uint8_t* data, int height, int width, int channels) {
  return Copy(data, height, width, channels, 255.0);
}

Image Image::FromFloat(const float* data, int height, int width, int channels, double data_range) {
  return Copy(data, height, width, channels, data_range);
}

Image Image::FromDouble(const double* data, int height, int width, int channels,
                        double data_range) {
  return Copy(data, height, width, channels, data_range);
}

std::string ShapeString(const Image& image) {
  return std::to_string(image.height) + "x" + std::to_string(image.width) + "x" +
         std::to_string(image.channels);
}

void CheckImage(const Image& image) {
  Check(image.height > 0 && image.width > 0,
        "image size must be positive, got " + ShapeString(image));
  Check(image.channels == 1 || image.channels == 3,
        "images must have 1 or 3 channels, got " + ShapeString(image));
  Check(image.pixels.size() == image.size(),
        "image " + ShapeString(image) + " holds " + std::to_string(image.pixels.size()) +
            " values, expected " + std::to_string(image.size()));
  Check(image.data_range > 0,
        "image data range must be positive, got " + std::to_string(image.data_range));
}

void CheckSameShape(const Image& a, const Image& b) {
  CheckImage(a);
  CheckImage(b);
  Check(a.height == b.height && a.width == b.width && a.channels == b.channels,
        "images differ in shape: " + ShapeString(a) + " vs " + ShapeString(b));
  Check(a.data_range == b.data_range,
        "images differ in data range: " + std::to_string(a.data_range) + " vs " +
            std::to_string(b.data_range) + " (compare uint8 with uint8, float with float)");
}

}  // namespace wm::metrics

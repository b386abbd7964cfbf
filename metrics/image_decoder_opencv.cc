// OpenCV's decoders behind image_io.cc (full builds); OpenCV stays inside this file.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "core/error.h"
#include "metrics/image_decoder.h"

namespace wm::metrics::internal {
namespace {

// An OpenCV matrix (1, 3 or 4 channels, BGR order) as an RGB or grey Image.
Image FromMat(const cv::Mat& decoded, const std::string& source) {
  cv::Mat mat;
  switch (decoded.channels()) {
    case 1:
      mat = decoded;
      break;
    case 3:
      cv::cvtColor(decoded, mat, cv::COLOR_BGR2RGB);
      break;
    case 4:
      cv::cvtColor(decoded, mat, cv::COLOR_BGRA2RGB);
      break;
    default:
      throw Error("unsupported channel count " + std::to_string(decoded.channels()) +
                      " (expected grey, RGB or RGBA)",
                  {.file = source});
  }
  double range = 0;
  switch (mat.depth()) {
    case CV_8U:
      range = 255.0;
      break;
    case CV_16U:
      range = 65535.0;
      break;
    case CV_32F:
      range = 1.0;
      break;
    default:
      throw Error("unsupported pixel depth (expected 8-bit, 16-bit or float)", {.file = source});
  }
  cv::Mat values;
  mat.convertTo(values, CV_64F);
  values = values.isContinuous() ? values : values.clone();
  return Image::FromDouble(values.ptr<double>(), values.rows, values.cols, values.channels(),
                           range);
}

}  // namespace

Image ReadImageFile(const std::string& path) {
  cv::Mat decoded = cv::imread(path, cv::IMREAD_UNCHANGED);
  Check(!decoded.empty(), "cannot decode image (corrupt or unsupported format)", {.file = path});
  return FromMat(decoded, path);
}

Image DecodeImageBytes(const std::string& bytes, const std::string& source) {
  const cv::Mat raw(1, static_cast<int>(bytes.size()), CV_8U,
                    const_cast<char*>(bytes.data()));  // imdecode only reads it
  cv::Mat decoded = cv::imdecode(raw, cv::IMREAD_UNCHANGED);
  Check(!decoded.empty(), "cannot decode image (corrupt or unsupported format)", {.file = source});
  return FromMat(decoded, source);
}

struct VideoDecoder::Impl {
  cv::VideoCapture capture;
};

VideoDecoder::VideoDecoder(const std::string& path) : impl_(std::make_unique<Impl>()) {
  impl_->capture.open(path);
  if (!impl_->capture.isOpened()) {
    throw Error("cannot open video (missing, not a video, or no decoder for its codec)",
                {.file = path});
  }
}

VideoDecoder::~VideoDecoder() = default;

bool VideoDecoder::Next(const std::string& source, Image* out) {
  cv::Mat frame;
  if (!impl_->capture.read(frame) || frame.empty()) return false;
  *out = FromMat(frame, source);
  return true;
}

}  // namespace wm::metrics::internal

#include "ingest/image_codec.h"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace wm::ingest {
namespace {

cv::Mat Decode(const std::string& encoded) {
  cv::Mat buf(1, static_cast<int>(encoded.size()), CV_8U, const_cast<char*>(encoded.data()));
  cv::Mat img = encoded.empty() ? cv::Mat() : cv::imdecode(buf, cv::IMREAD_UNCHANGED);
  Check(!img.empty(), "image bytes do not decode (" + std::to_string(encoded.size()) +
                          " bytes, expected a JPEG or PNG)");
  return img;
}

std::string Encode(const cv::Mat& img, const std::string& encoding) {
  std::vector<uchar> out;
  std::vector<int> params;
  if (encoding == "jpeg") params = {cv::IMWRITE_JPEG_QUALITY, 95};
  if (encoding == "png") params = {cv::IMWRITE_PNG_COMPRESSION, 3};
  Check(cv::imencode(encoding == "jpeg" ? ".jpg" : ".png", img, out, params),
        "cannot encode image as " + encoding);
  return {out.begin(), out.end()};
}

ImageInfo InfoOf(const cv::Mat& img) {
  return {img.rows, img.cols, img.channels(), img.depth() == CV_16U ? "uint16" : "uint8"};
}

}  // namespace

std::string SniffEncoding(const std::string& b) {
  if (b.size() >= 3 && static_cast<uint8_t>(b[0]) == 0xFF && static_cast<uint8_t>(b[1]) == 0xD8 &&
      static_cast<uint8_t>(b[2]) == 0xFF) {
    return "jpeg";
  }
  if (b.size() >= 8 && b.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0) return "png";
  return "";
}

ImageInfo DecodeInfo(const std::string& encoded) {
  cv::Mat img = Decode(encoded);
  Check(img.depth() == CV_8U || img.depth() == CV_16U, "image must be 8- or 16-bit");
  return InfoOf(img);
}

void CheckFrames(EncodedFrames& frames, bool full) {
  for (size_t t = 0; t < frames.frames.size(); ++t) {
    const std::string& f = frames.frames[t];
    try {
      std::string enc = SniffEncoding(f);
      Check(!enc.empty(), "image is neither JPEG nor PNG");
      if (frames.encoding.empty()) frames.encoding = enc;
      Check(enc == frames.encoding,
            "frame is " + enc + " but earlier frames are " + frames.encoding);
      if (!full && t > 0) continue;
      ImageInfo info = DecodeInfo(f);
      if (t == 0 && frames.height == 0) {
        frames.height = info.height, frames.width = info.width, frames.channels = info.channels;
        frames.dtype = info.dtype;
      }
      Check(info.height == frames.height && info.width == frames.width &&
                info.channels == frames.channels && info.dtype == frames.dtype,
            "frame is " + std::to_string(info.height) + "x" + std::to_string(info.width) + "x" +
                std::to_string(info.channels) + " " + info.dtype + ", expected " +
                std::to_string(frames.height) + "x" + std::to_string(frames.width) + "x" +
                std::to_string(frames.channels) + " " + frames.dtype);
    } catch (const Error& e) {
      throw Error(e.message() + " (step " + std::to_string(t) + ")", e.context());
    }
  }
}

void ResizeFrames(EncodedFrames& frames, int width, int height, bool nearest) {
  for (auto& f : frames.frames) {
    cv::Mat img = Decode(f), out;
    cv::resize(img, out, cv::Size(width, height), 0, 0,
               nearest ? cv::INTER_NEAREST : cv::INTER_AREA);
    f = Encode(out, frames.encoding);
  }
  frames.width = width;
  frames.height = height;
}

std::string EncodeRgb(const uint8_t* pixels, int height, int width, int channels,
                      const std::string& encoding) {
  cv::Mat rgb(height, width, CV_8UC(channels), const_cast<uint8_t*>(pixels)), bgr;
  if (channels == 3) {
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  } else {
    bgr = rgb;
  }
  return Encode(bgr, encoding);
}

}  // namespace wm::ingest

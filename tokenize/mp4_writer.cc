#include "tokenize/mp4_writer.h"

#include <spdlog/spdlog.h>

#include <filesystem>
#include <opencv2/videoio.hpp>

#include "core/error.h"
#include "ingest/video/h264_writer.h"

namespace wm::tokenize {
namespace fs = std::filesystem;
namespace {

// The H.264 writer's errors name the hidden file; the user asked for `path`.
template <typename Step>
void NamingTarget(const std::string& path, Step&& step) {
  try {
    step();
  } catch (const Error& e) {
    throw Error(e.message(), {.file = path});
  }
}

}  // namespace

struct Mp4Writer::Impl {
  std::string path, temp;
  std::unique_ptr<ingest::H264Writer> h264;
  cv::VideoWriter mp4v;  // only where there is no H.264 encoder
  int64_t frames = 0;
  bool committed = false;
};

Mp4Writer::Mp4Writer(std::string path, double fps, int width, int height,
                     const std::string& h264_encoder)
    : impl_(std::make_unique<Impl>()) {
  const fs::path target(path);
  impl_->temp = (target.parent_path() / ("." + target.stem().string() + ".tmp.mp4")).string();
  impl_->path = std::move(path);
  NamingTarget(impl_->path, [&] {
    impl_->h264 = ingest::H264Writer::Open(
        impl_->temp, {.fps = fps, .width = width, .height = height, .encoder = h264_encoder});
  });
  if (impl_->h264) return;
  spdlog::warn("{}: no H.264 encoder '{}' in this FFmpeg; writing mp4v, which browsers do not play",
               impl_->path, h264_encoder);
  impl_->mp4v.open(impl_->temp, cv::VideoWriter::fourcc('m', 'p', '4', 'v'), fps,
                   cv::Size(width, height));
  Check(impl_->mp4v.isOpened(), "cannot open video writer (mp4v)", {.file = impl_->path});
}

Mp4Writer::~Mp4Writer() {
  if (impl_->committed) return;
  impl_->h264.reset();
  impl_->mp4v.release();
  std::error_code ignored;
  fs::remove(impl_->temp, ignored);
}

void Mp4Writer::Write(const cv::Mat& bgr_frame) {
  if (impl_->h264) {
    const cv::Mat packed = bgr_frame.isContinuous() ? bgr_frame : bgr_frame.clone();
    NamingTarget(impl_->path, [&] { impl_->h264->Write(packed.data, packed.step); });
  } else {
    impl_->mp4v.write(bgr_frame);
  }
  ++impl_->frames;
}

void Mp4Writer::Commit() {
  if (impl_->h264) NamingTarget(impl_->path, [&] { impl_->h264->Finish(); });
  impl_->mp4v.release();
  int64_t readable = 0;
  cv::VideoCapture check(impl_->temp, cv::CAP_FFMPEG);
  for (cv::Mat frame; check.isOpened() && check.read(frame);) ++readable;
  check.release();
  Check(readable == impl_->frames,
        "video is incomplete after writing (" + std::to_string(readable) + " of " +
            std::to_string(impl_->frames) + " frames readable; disk full?)",
        {.file = impl_->path});
  fs::rename(impl_->temp, impl_->path);
  impl_->committed = true;
}

}  // namespace wm::tokenize

#include "tokenize/mp4_writer.h"

#include <filesystem>
#include <opencv2/videoio.hpp>

#include "core/error.h"

namespace wm::tokenize {
namespace fs = std::filesystem;

struct Mp4Writer::Impl {
  std::string path, temp;
  cv::VideoWriter video;
  int64_t frames = 0;
  bool committed = false;
};

Mp4Writer::Mp4Writer(std::string path, double fps, int width, int height)
    : impl_(std::make_unique<Impl>()) {
  const fs::path target(path);
  impl_->temp = (target.parent_path() / ("." + target.stem().string() + ".tmp.mp4")).string();
  impl_->path = std::move(path);
  impl_->video.open(impl_->temp, cv::VideoWriter::fourcc('m', 'p', '4', 'v'), fps,
                    cv::Size(width, height));
  Check(impl_->video.isOpened(), "cannot open video writer (mp4v)", {.file = impl_->path});
}

Mp4Writer::~Mp4Writer() {
  if (impl_->committed) return;
  impl_->video.release();
  std::error_code ignored;
  fs::remove(impl_->temp, ignored);
}

void Mp4Writer::Write(const cv::Mat& bgr_frame) {
  impl_->video.write(bgr_frame);
  ++impl_->frames;
}

void Mp4Writer::Commit() {
  impl_->video.release();
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

#pragma once
// MP4 files that are whole or absent, H.264 (avc1) so browsers and W&B play them, or mp4v where
// this FFmpeg has no H.264 encoder (one warning). Writers write in place and may ignore failed
// writes, so a full disk left a truncated video and no error, and a killed run a truncated file
// under the real name. Used by `wm-tokenize decode` and wm-eval's videos.
#include <cstdint>
#include <memory>
#include <string>

namespace cv {
class Mat;
}

namespace wm::tokenize {

class Mp4Writer {
 public:
  // Frames of `width` x `height` px go to the hidden `.NAME.tmp.mp4` beside `path`, encoded by
  // the libavcodec encoder `h264_encoder` (ingest/video/h264_writer.h); when there is none, by
  // OpenCV's mp4v. Throws wm::Error naming `path` if it cannot open.
  Mp4Writer(std::string path, double fps, int width, int height,
            const std::string& h264_encoder = "libx264");
  ~Mp4Writer();  // removes the hidden file unless committed
  Mp4Writer(const Mp4Writer&) = delete;
  Mp4Writer& operator=(const Mp4Writer&) = delete;

  void Write(const cv::Mat& bgr_frame);
  // Reads the file back and renames it to `path` only if every written frame decodes; else
  // removes it and throws wm::Error naming `path`.
  void Commit();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace wm::tokenize

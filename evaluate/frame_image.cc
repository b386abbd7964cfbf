#include "evaluate/frame_image.h"

#include <opencv2/imgproc.hpp>

#include "evaluate/frame_scores.h"
#include "tokenize/tokenizer.h"

namespace wm::evaluate {

cv::Mat ClipFrameBgr(const Clip& clip, int64_t t) {
  std::vector<uint8_t> rgb = tokenize::PlanarToRgb8(clip.frame(t), clip.size);
  cv::Mat bgr;
  cv::cvtColor(cv::Mat(clip.size, clip.size, CV_8UC3, rgb.data()), bgr, cv::COLOR_RGB2BGR);
  return bgr;
}

cv::Mat ErrorHeatMap(const cv::Mat& real_bgr, const cv::Mat& pred_bgr) {
  cv::Mat diff, grey, heat;
  cv::absdiff(real_bgr, pred_bgr, diff);
  cv::cvtColor(diff, grey, cv::COLOR_BGR2GRAY);
  cv::applyColorMap(grey * 3, heat, cv::COLORMAP_JET);
  return heat;
}

}  // namespace wm::evaluate

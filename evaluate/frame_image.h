#pragma once
// A clip's frames as OpenCV images and the error heat map drawn under rollouts, shared by the
// videos (clip_video.cc) and the strips (episode_strip.cc). cv::Mat is only declared here, so
// this header stays free of OpenCV; its callers are .cc files that include OpenCV themselves.
#include <cstdint>

namespace cv {
class Mat;
}

namespace wm::evaluate {

struct Clip;

// Frame t of `clip` as an 8-bit BGR image of clip.size x clip.size (tokenize::PlanarToRgb8's
// rounding: the pixels every metric scores).
cv::Mat ClipFrameBgr(const Clip& clip, int64_t t);

// |real - pred| as a JET heat map: grey error x3, so 85 levels and more are the hottest red.
cv::Mat ErrorHeatMap(const cv::Mat& real_bgr, const cv::Mat& pred_bgr);

}  // namespace wm::evaluate

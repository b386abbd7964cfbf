#include "evaluate/clip_video.h"

#include <filesystem>
#include <opencv2/imgproc.hpp>

#include "tokenize/mp4_writer.h"
#include "tokenize/tokenizer.h"

namespace wm::evaluate {
namespace {

cv::Mat Bgr(const Clip& clip, int64_t t) {
  std::vector<uint8_t> rgb = tokenize::PlanarToRgb8(clip.frame(t), clip.size);
  cv::Mat bgr;
  cv::cvtColor(cv::Mat(clip.size, clip.size, CV_8UC3, rgb.data()), bgr, cv::COLOR_RGB2BGR);
  return bgr;
}

}  // namespace

void WriteClipVideo(const std::string& dir, int64_t episode, const Clip& real,
                    const std::map<std::string, Clip>& rollouts) {
  std::filesystem::create_directories(dir);
  const std::string path =
      (std::filesystem::path(dir) / ("episode_" + std::to_string(episode) + ".mp4")).string();
  const int panels = 1 + static_cast<int>(rollouts.size()) + (rollouts.empty() ? 0 : 1);
  const int scale = 2;  // 64 px frames are too small to look at
  tokenize::Mp4Writer video(path, 4.0, panels * real.size * scale, real.size * scale);
  for (int64_t t = 0; t < real.frames; ++t) {
    std::vector<cv::Mat> row = {Bgr(real, t)};
    for (const auto& [name, clip] : rollouts) row.push_back(Bgr(clip, t));
    if (!rollouts.empty()) {
      cv::Mat diff, grey, heat;
      cv::absdiff(row[0], row[1], diff);
      cv::cvtColor(diff, grey, cv::COLOR_BGR2GRAY);
      cv::applyColorMap(grey * 3, heat, cv::COLORMAP_JET);
      row.push_back(heat);
    }
    cv::Mat strip, big;
    cv::hconcat(row, strip);
    cv::resize(strip, big, cv::Size(), scale, scale, cv::INTER_NEAREST);
    video.Write(big);
  }
  video.Commit();  // whole or an error naming the file (VideoWriter ignores failed writes)
}

}  // namespace wm::evaluate

#include "evaluate/clip_video.h"

#include <filesystem>
#include <opencv2/imgproc.hpp>

#include "evaluate/frame_image.h"
#include "tokenize/mp4_writer.h"

namespace wm::evaluate {

void WriteClipVideo(const std::string& dir, int64_t episode, const Clip& real,
                    const std::map<std::string, Clip>& rollouts) {
  std::filesystem::create_directories(dir);
  const std::string path =
      (std::filesystem::path(dir) / ("episode_" + std::to_string(episode) + ".mp4")).string();
  const int panels = 1 + static_cast<int>(rollouts.size()) + (rollouts.empty() ? 0 : 1);
  const int scale = 2;  // 64 px frames are too small to look at
  tokenize::Mp4Writer video(path, 4.0, panels * real.size * scale, real.size * scale);
  for (int64_t t = 0; t < real.frames; ++t) {
    std::vector<cv::Mat> row = {ClipFrameBgr(real, t)};
    for (const auto& [name, clip] : rollouts) row.push_back(ClipFrameBgr(clip, t));
    if (!rollouts.empty()) row.push_back(ErrorHeatMap(row[0], row[1]));
    cv::Mat strip, big;
    cv::hconcat(row, strip);
    cv::resize(strip, big, cv::Size(), scale, scale, cv::INTER_NEAREST);
    video.Write(big);
  }
  video.Commit();  // whole or an error naming the file (VideoWriter ignores failed writes)
}

}  // namespace wm::evaluate

#include "ingest/tabletop/closed_loop.h"

#include <cstring>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace wm::tabletop {

std::vector<uint8_t> DecodeJpegRgb(const std::string& jpeg, int size) {
  const cv::Mat bytes(1, static_cast<int>(jpeg.size()), CV_8UC1, const_cast<char*>(jpeg.data()));
  const cv::Mat bgr = cv::imdecode(bytes, cv::IMREAD_COLOR);
  Check(bgr.rows == size && bgr.cols == size && bgr.type() == CV_8UC3,
        "a rendered frame's JPEG does not decode to " + std::to_string(size) + "x" +
            std::to_string(size) + " RGB",
        {.key = kImageKey});
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  std::vector<uint8_t> out(static_cast<size_t>(size) * size * 3);
  std::memcpy(out.data(), rgb.data, out.size());  // cvtColor's output is continuous
  return out;
}

ClosedLoopEpisode RollOutClosedLoop(uint64_t episode_seed, int max_steps, LookVariation look,
                                    int size, const ImagePolicy& policy) {
  ClosedLoopEpisode out;
  out.rollout = RollOutWith(episode_seed, max_steps, look, [&](const Scene& scene, int step, Rng&) {
    out.frames.push_back(RenderEncodedFrame(scene, size));
    const std::vector<uint8_t> rgb = DecodeJpegRgb(out.frames.back().jpeg, size);
    return policy({rgb, size, scene.look.instruction, step});
  });
  // The terminal step (block in the goal) asked no action, so its frame is still to render.
  for (size_t i = out.frames.size(); i < out.rollout.steps.size(); ++i) {
    out.frames.push_back(RenderEncodedFrame({out.rollout.steps[i].state, out.rollout.look}, size));
  }
  for (const EpisodeStep& s : out.rollout.steps) out.episode_return += s.reward;
  return out;
}

}  // namespace wm::tabletop

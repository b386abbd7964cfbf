// WM_MODEL_ONLY builds have no OpenCV (docs/gpu.md): wm-eval scores and exports as usual and
// skips the optional side-by-side videos and PNG strips with one warning each, rather than
// failing the evaluation.
#include <spdlog/spdlog.h>

#include <atomic>

#include "evaluate/clip_video.h"
#include "evaluate/episode_strip.h"

namespace wm::evaluate {
namespace {

void WarnOnce(std::atomic<bool>& warned, const std::string& what, const std::string& dir) {
  if (!warned.exchange(true))
    spdlog::warn("{}: {} skipped: this wmkit build has no OpenCV (WM_MODEL_ONLY)", dir, what);
}

}  // namespace

void WriteClipVideo(const std::string& dir, int64_t, const Clip&,
                    const std::map<std::string, Clip>&) {
  static std::atomic<bool> warned{false};
  WarnOnce(warned, "videos", dir);
}

void WriteEpisodeStrip(const std::string& dir, int64_t, const Clip&,
                       const std::map<std::string, Clip>&) {
  static std::atomic<bool> warned{false};
  WarnOnce(warned, "strips", dir);
}

void WriteStripOverview(const std::string&, const std::vector<int64_t>&, int, int) {}

}  // namespace wm::evaluate

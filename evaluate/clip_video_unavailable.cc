// WM_MODEL_ONLY builds have no OpenCV (docs/gpu.md): wm-eval scores as usual and skips the
// optional side-by-side videos with one warning rather than failing the evaluation.
#include <spdlog/spdlog.h>

#include <atomic>

#include "evaluate/clip_video.h"

namespace wm::evaluate {

void WriteClipVideo(const std::string& dir, int64_t, const Clip&,
                    const std::map<std::string, Clip>&) {
  static std::atomic<bool> warned{false};
  if (!warned.exchange(true))
    spdlog::warn("{}: videos skipped: this wmkit build has no OpenCV (WM_MODEL_ONLY)", dir);
}

}  // namespace wm::evaluate

// WM_MODEL_ONLY builds have neither OpenCV nor PCL (docs/gpu.md): the motion and depth mask
// sources say so; label files (segmentation streams in shards) work as in full builds.
#include "core/error.h"
#include "metrics/segmentation/mask_source.h"

namespace wm::metrics::seg {

std::unique_ptr<MaskSource> MakeMotionMaskSource(const MotionMaskOptions&) {
  throw Error("motion masks need OpenCV; this wmkit build has none (WM_MODEL_ONLY)");
}

std::unique_ptr<MaskSource> MakeDepthMaskSource(Frames, const DepthMaskOptions&) {
  throw Error("depth masks need PCL; this wmkit build has none (WM_MODEL_ONLY)");
}

}  // namespace wm::metrics::seg

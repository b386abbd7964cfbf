#include "motion/motion_prior.h"

namespace wm::motion {

torch::Tensor Differs(const torch::Tensor& frames, const torch::Tensor& others, double levels) {
  return ((frames - others).abs().amax(-3, /*keepdim=*/true) > levels / 127.5)
      .to(frames.scalar_type());
}

torch::Tensor MovedPixels(const torch::Tensor& frames, int64_t given, double levels) {
  const torch::Tensor later = frames.narrow(1, given + 1, frames.size(1) - given - 1);
  const torch::Tensor moved = Differs(later, frames.narrow(1, given, 1), levels).amax(1);
  return torch::max_pool2d(moved, 3, 1, 1).squeeze(1);
}

torch::Tensor MotionPriorLoss(const torch::Tensor& masks, const torch::Tensor& moved) {
  // clamped as torch's BCE would otherwise take log(0) of a saturated mask
  const torch::Tensor covered = (1 - torch::prod(1 - masks, 1)).clamp(1e-4, 1 - 1e-4);
  return torch::binary_cross_entropy(covered, moved);
}

torch::Tensor MovedLossWeights(const torch::Tensor& moved, double moved_weight) {
  if (moved_weight <= 0) return {};
  const torch::Tensor weights = (1 + moved_weight * moved).unsqueeze(1);
  return weights / weights.mean();
}

torch::Tensor FrameL1(const torch::Tensor& imagined, const torch::Tensor& real,
                      const torch::Tensor& weights) {
  const torch::Tensor error = (imagined - real).abs();
  return weights.defined() ? (error * weights).mean() : error.mean();
}

double MotionPriorWeight(const TrainConfig& t, int64_t step) {
  const double span = t.motion_prior_steps * static_cast<double>(t.steps);
  if (t.motion_prior <= 0 || static_cast<double>(step) >= span) return 0;
  return t.motion_prior * (1 - static_cast<double>(step) / span);
}

}  // namespace wm::motion

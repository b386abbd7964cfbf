#pragma once
// The pose kind's two training phases (pose_net.h; docs/motion.md, "The pose kind"), the losses
// trainer.cc's loop minimises: train.steps of the autoencoder, then train.dynamics_steps of the
// dynamics on the frozen encoder's poses. Internal (includes torch).
#include <torch/torch.h>

#include <vector>

#include "motion/config.h"
#include "motion/pose_net.h"
#include "motion/window_sampler.h"

namespace wm::motion {

// metrics.csv's model columns for a step: the drawn arm's mean alpha and the share of pixels
// weighed as drawn (0 in the dynamics' steps).
struct PoseDiagnostics {
  torch::Tensor alpha, drawn;
};

// frames x_t and sources x_s [B, 3, S, S] of the same episodes: x_t drawn from its pose over
// x_s's background; the squared error for the first train.squared_until of train.steps, the L1
// after, the pixels where x_t differs from the (detached) background weighed 1 +
// train.moved_weight; plus train.mask_l1 x the mean alpha; plus train.edge_weight x the same norm
// of GradientDifference(drawn frame, x_t) along x and along y.
torch::Tensor PoseAutoencoderLoss(PoseNet& net, const TrainConfig& train,
                                  const torch::Tensor& frames, const torch::Tensor& sources,
                                  int64_t step, PoseDiagnostics& diagnostics);

// The image-gradient difference of Mathieu et al. 2016 ("Deep multi-scale video prediction beyond
// mean square error"): {horizontal, vertical} differences of neighbouring pixels of `predicted`
// minus those of `target` [B, C, H, W]: [B, C, H, W-1] and [B, C, H-1, W]. A blurred arm can
// match a frame's colours on average, not its edges.
std::vector<torch::Tensor> GradientDifference(const torch::Tensor& predicted,
                                              const torch::Tensor& target);

// train.calibrate_alpha: the renderer's alpha logit shifted (DeconvRenderer::ShiftAlpha) by the
// value of -2 to 2 in eighths whose open-loop rollouts of the first 64 training episodes
// (`unroll` steps from their first frame) have the least plain squared error. The
// training loss weighs the pixels that differ from the background 1 + moved_weight, which makes
// drawing there cheaper than not drawing: the arm ends too opaque where the renderer is unsure,
// a grey blob over the table and the block (docs/motion.md, session 41).
struct AlphaShiftFit {
  double shift = 0;
  double mse_before = 0, mse_after = 0;  // mean squared error on [-1, 1] values
  int64_t episodes = 0;
};
AlphaShiftFit FitAlphaShift(PoseNet& net, const WindowSampler& sampler, int64_t unroll,
                            int64_t image_size, const torch::Device& device);

// The dynamics' phase: every training episode's poses, read once by the frozen encoder, and
// batches of open-loop pose rollouts of train.unroll steps against them.
class PoseDynamicsTraining {
 public:
  PoseDynamicsTraining(PoseNet& net, const WindowSampler& sampler, int64_t image_size,
                       const torch::Device& device);
  // Rollouts from the windows WindowSampler::Draw(seed, step, train.dynamics_batch) gives: the
  // mean squared error of the poses, each number's error divided by its spread over the
  // training poses.
  torch::Tensor Loss(PoseNet& net, const TrainConfig& train, int64_t step) const;

 private:
  const WindowSampler& sampler_;
  std::vector<torch::Tensor> poses_;    // per dataset episode: [T, P] (undefined: not drawn)
  std::vector<torch::Tensor> actions_;  // per dataset episode: [T, D] normalised
  torch::Tensor scale_;                 // [P]
};

}  // namespace wm::motion

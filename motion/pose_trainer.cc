#include "motion/pose_trainer.h"

#include <limits>

#include "core/error.h"
#include "motion/motion_net.h"
#include "motion/motion_prior.h"

namespace wm::motion {
namespace {

// Frames the frozen encoder reads at once when it reads the training episodes.
constexpr int64_t kEncodeChunk = 256;
// FitAlphaShift's episodes and the shifts it tries: -2 to 2 in steps of 1/8.
constexpr int kCalibrationEpisodes = 64;
constexpr int kShiftSteps = 32;
constexpr double kShiftMin = -2, kShiftMax = 2;

// One training episode's open-loop rollout, drawn: colour, alpha logit, the start frame's
// background, and the real frames it should match.
struct DrawnRollout {
  Drawn drawn;
  torch::Tensor background, real;
};

DrawnRollout DrawRollout(PoseNet& net, const EpisodeClip& clip, const trainkit::ActionNorm& norm,
                         int64_t image_size, const torch::Device& device) {
  const ClipTensors clip_tensors = RolloutTensors(clip, norm, image_size);
  const torch::Tensor frames = clip_tensors.frames.to(device);
  const torch::Tensor actions = clip_tensors.actions.to(device);
  PoseRollout r = net->Start(frames.slice(0, 0, 1));
  std::vector<torch::Tensor> poses;
  for (int64_t t = 0; t < actions.size(0); ++t) {
    r.pose = net->dynamics()->forward(r.pose, actions.slice(0, t, t + 1));
    poses.push_back(r.pose);
  }
  return {net->renderer()->Logits(torch::cat(poses)), r.background, frames.slice(0, 1)};
}

}  // namespace

std::vector<torch::Tensor> GradientDifference(const torch::Tensor& predicted,
                                              const torch::Tensor& target) {
  return {torch::diff(predicted, 1, 3) - torch::diff(target, 1, 3),
          torch::diff(predicted, 1, 2) - torch::diff(target, 1, 2)};
}

torch::Tensor PoseAutoencoderLoss(PoseNet& net, const TrainConfig& train,
                                  const torch::Tensor& frames, const torch::Tensor& sources,
                                  int64_t step, PoseDiagnostics& diagnostics) {
  const Drawn drawn = net->renderer()->forward(net->encoder()->forward(frames));
  const torch::Tensor background = net->Background(sources);
  const torch::Tensor composed = drawn.Over(background);
  torch::Tensor error = composed - frames;
  // What the renderer must draw (the arm, its shadow) counts more, but not what the eraser
  // removed from x_s: weighing that too made the renderer repaint the table (measured).
  const torch::Tensor weighed = Differs(frames, background.detach());
  if (train.moved_weight > 0) error = error * (1 + train.moved_weight * weighed);
  // Squared first: while the pose says nothing yet, the L1's best guess at each pixel is its
  // median, no arm, and the alpha dies before the pose can learn (measured).
  const bool squared = static_cast<double>(step) < train.squared_until * train.steps;
  const auto norm = [squared](const torch::Tensor& e) {
    return squared ? e.square().mean() : e.abs().mean();
  };
  const torch::Tensor alpha = drawn.alpha.mean();
  diagnostics = {alpha.detach(), weighed.mean()};
  torch::Tensor loss = norm(error) + train.mask_l1 * alpha;
  if (train.edge_weight > 0)
    for (const torch::Tensor& e : GradientDifference(composed, frames))
      loss = loss + train.edge_weight * norm(e);
  return loss;
}

PoseDynamicsTraining::PoseDynamicsTraining(PoseNet& net, const WindowSampler& sampler,
                                           int64_t image_size, const torch::Device& device)
    : sampler_(sampler) {
  torch::NoGradGuard no_grad;
  const int64_t D = sampler.action_dim();
  std::vector<torch::Tensor> all;
  for (const int64_t k : sampler.episodes()) {
    EpisodeClip clip = sampler.Clip(k, std::numeric_limits<int64_t>::max());
    const int64_t T = clip.frames, S = image_size;
    const torch::Tensor frames = torch::from_blob(clip.pixels.data(), {T, 3, S, S}).to(device);
    std::vector<torch::Tensor> chunks;
    for (int64_t t = 0; t < T; t += kEncodeChunk)
      chunks.push_back(net->encoder()->forward(frames.slice(0, t, t + kEncodeChunk)));
    std::vector<float> normed(static_cast<size_t>(T * D));
    sampler.action_norm().Apply(clip.actions.data(), normed.data(), T);
    if (poses_.size() <= static_cast<size_t>(k)) poses_.resize(k + 1), actions_.resize(k + 1);
    poses_[k] = torch::cat(chunks);
    actions_[k] = torch::from_blob(normed.data(), {T, D}).to(device).clone();
    all.push_back(poses_[k]);
  }
  // Each number's spread: a pose number that barely moves must not be drowned by one that does.
  scale_ = torch::cat(all).std(0) + 1e-3;
}

torch::Tensor PoseDynamicsTraining::Loss(PoseNet& net, const TrainConfig& train,
                                         int64_t step) const {
  const int64_t H = train.unroll;
  std::vector<torch::Tensor> first, targets, actions;
  for (const WindowRef& w : sampler_.Draw(train.seed, step, train.dynamics_batch)) {
    const torch::Tensor& poses = poses_[static_cast<size_t>(w.episode)];
    first.push_back(poses[w.start]);
    targets.push_back(poses.slice(0, w.start + 1, w.start + H + 1));
    actions.push_back(actions_[static_cast<size_t>(w.episode)].slice(0, w.start, w.start + H));
  }
  torch::Tensor pose = torch::stack(first);
  const torch::Tensor target = torch::stack(targets), action = torch::stack(actions);
  torch::Tensor loss = torch::zeros({}, pose.options());
  for (int64_t h = 0; h < H; ++h) {
    pose = net->dynamics()->forward(pose, action.select(1, h));
    loss = loss + ((pose - target.select(1, h)) / scale_).square().mean() / static_cast<double>(H);
  }
  return loss;
}

AlphaShiftFit FitAlphaShift(PoseNet& net, const WindowSampler& sampler, int64_t unroll,
                            int64_t image_size, const torch::Device& device) {
  torch::NoGradGuard no_grad;
  std::vector<DrawnRollout> rollouts;
  for (const EpisodeClip& clip : sampler.Episodes(kCalibrationEpisodes, unroll + 1)) {
    if (clip.frames < 2) continue;
    rollouts.push_back(DrawRollout(net, clip, sampler.action_norm(), image_size, device));
  }
  Check(!rollouts.empty(), "no training episode has two frames to calibrate the alpha on");
  const auto mse = [&](double shift) {
    double sum = 0;
    int64_t count = 0;
    for (const DrawnRollout& r : rollouts) {
      const Drawn d{r.drawn.rgb, torch::sigmoid(r.drawn.alpha + shift)};
      sum += (d.Over(r.background) - r.real).square().sum().item<double>();
      count += r.real.numel();
    }
    return sum / static_cast<double>(count);
  };
  AlphaShiftFit fit{.mse_before = mse(0), .episodes = static_cast<int64_t>(rollouts.size())};
  fit.mse_after = fit.mse_before;
  for (int i = 0; i <= kShiftSteps; ++i) {
    const double shift = kShiftMin + (kShiftMax - kShiftMin) * i / kShiftSteps;
    const double e = mse(shift);
    if (e < fit.mse_after) fit = {shift, fit.mse_before, e, fit.episodes};
  }
  net->renderer()->ShiftAlpha(fit.shift);
  return fit;
}

}  // namespace wm::motion

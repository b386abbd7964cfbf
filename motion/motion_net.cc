#include "motion/motion_net.h"

namespace wm::motion {

MotionNet::MotionNet(const ModelConfig& config, int64_t action_dim) : action_dim_(action_dim) {
  if (config.kind == "layers") {
    layers_ = LayerNet(config, action_dim);
  } else if (config.kind == "pose") {
    pose_ = PoseNet(config, action_dim);
  } else {
    warp_ = WarpNet(config, action_dim);
  }
}

torch::nn::Module& MotionNet::module() {
  if (layered()) return *layers_;
  if (posed()) return *pose_;
  return *warp_;
}

Rollout::Rollout(MotionNet& net, const torch::Tensor& first)
    : net_(net), current_(first), previous_(first) {
  if (net_.layered()) layers_ = net_.layers()->Start(first);
  if (net_.posed()) pose_ = net_.pose()->Start(first);
}

torch::Tensor Rollout::Next(const torch::Tensor& action) {
  if (net_.layered()) return net_.layers()->Advance(layers_, action).clamp(-1, 1);
  if (net_.posed()) return net_.pose()->Advance(pose_, action).clamp(-1, 1);
  torch::Tensor next = net_.warp()->forward(current_, previous_, action).next.clamp(-1, 1);
  previous_ = current_;
  current_ = next;
  return next;
}

torch::Tensor Imagine(MotionNet& net, const torch::Tensor& first, const torch::Tensor& actions) {
  torch::NoGradGuard no_grad;
  Rollout rollout(net, first);
  std::vector<torch::Tensor> frames;
  for (int64_t h = 0; h < actions.size(1); ++h)
    frames.push_back(rollout.Next(actions.select(1, h)));
  return torch::stack(frames, 1);
}

ClipTensors RolloutTensors(const EpisodeClip& clip, const trainkit::ActionNorm& norm,
                           int64_t image_size) {
  const int64_t T = clip.frames, S = image_size, D = norm.dim();
  std::vector<float> normed(static_cast<size_t>((T - 1) * D));
  norm.Apply(clip.actions.data(), normed.data(), T - 1);
  return {torch::from_blob(const_cast<float*>(clip.pixels.data()), {T, 3, S, S}).clone(),
          torch::from_blob(normed.data(), {T - 1, D}).clone()};
}

}  // namespace wm::motion

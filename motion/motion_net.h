#pragma once
// The motion model of any kind (model.kind: warp_net.h, layer_net.h, pose_net.h) behind one
// interface:
// the module to train, save and load, and rollouts one step at a time. Internal (includes torch);
// the torch-free API is motion/motion_model.h.
#include <torch/torch.h>

#include "motion/layer_net.h"
#include "motion/pose_net.h"
#include "motion/warp_net.h"
#include "motion/window_sampler.h"

namespace wm::motion {

class MotionNet {
 public:
  MotionNet(const ModelConfig& config, int64_t action_dim);

  // The one module of this kind: parameters, archives, device, train/eval mode.
  torch::nn::Module& module();
  bool layered() const { return !layers_.is_empty(); }
  bool posed() const { return !pose_.is_empty(); }
  WarpNet& warp() { return warp_; }
  LayerNet& layers() { return layers_; }
  PoseNet& pose() { return pose_; }
  int64_t action_dim() const { return action_dim_; }

 private:
  WarpNet warp_{nullptr};
  LayerNet layers_{nullptr};
  PoseNet pose_{nullptr};
  int64_t action_dim_;
};

// One open-loop rollout from `first` ([B, 3, S, S] in [-1, 1]): Next(action) is the frame after
// the last under normalised actions [B, D], clamped to [-1, 1]. A warp rollout feeds each
// frame back as the next step's current frame; a layered one moves the start frame's layers; a
// pose one moves the pose and draws it over the start frame's background.
// Holds a reference to `net`, which must outlive it.
class Rollout {
 public:
  Rollout(MotionNet& net, const torch::Tensor& first);
  torch::Tensor Next(const torch::Tensor& action);

 private:
  MotionNet& net_;
  torch::Tensor current_, previous_;  // warp
  LayerRollout layers_;               // layers
  PoseRollout pose_;                  // pose
};

// Open-loop imagination: actions.size(1) frames after `first` under normalised actions
// [B, H, D]: a Rollout's frames stacked, [B, H, 3, S, S]. No gradient.
torch::Tensor Imagine(MotionNet& net, const torch::Tensor& first, const torch::Tensor& actions);

// An episode clip as an open-loop rollout's input and target: its frames [T, 3, S, S] (frame 0
// the start, the rest the real frames to match) and the T - 1 actions between them, normalised
// by `norm` [T - 1, D]. Both own their memory (the clip may die first).
struct ClipTensors {
  torch::Tensor frames, actions;
};
ClipTensors RolloutTensors(const EpisodeClip& clip, const trainkit::ActionNorm& norm,
                           int64_t image_size);

}  // namespace wm::motion

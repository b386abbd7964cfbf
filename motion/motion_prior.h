#pragma once
// The layered kind's motion prior (train.motion_prior; docs/motion.md, "The motion prior"):
// early in training, a cross-entropy pulls the union of the layers' masks towards the pixels
// that change within the training window. Without it, on a textured table the masks grow over
// the whole frame before any motion is learned (covering the grey initial fill pays at once),
// and a layer holding the whole table cannot move: the model copies the given frame. The target
// comes from the frames alone, so no segmentation labels are needed. The same pixels can also
// weigh more in the frame loss (train.moved_weight; "Weighing the pixels that move"): the arm
// and the block are a few percent of the frame. Internal (includes torch).
#include <torch/torch.h>

#include "motion/config.h"

namespace wm::motion {

// [..., 1, S, S]: 1 where `frames` and `others` [..., 3, S, S] (in [-1, 1]) differ by more than
// `levels` (of 255) in some channel, else 0.
torch::Tensor Differs(const torch::Tensor& frames, const torch::Tensor& others, double levels = 30);

// frames [B, W, 3, S, S] in [-1, 1] with the given frame at index `given`: [B, S, S], 1 where a
// later frame of the window differs from the given one by more than `levels` (of 255) in some
// channel, grown by one pixel (3x3 max), else 0. Earlier frames are ignored.
torch::Tensor MovedPixels(const torch::Tensor& frames, int64_t given, double levels = 30);

// The mean binary cross-entropy of the layers' union 1 - prod_k (1 - m_k) (masks [B, K, S, S])
// against `moved` [B, S, S].
torch::Tensor MotionPriorLoss(const torch::Tensor& masks, const torch::Tensor& moved);

// Per-pixel weights [B, 1, S, S] of the frame loss: 1 + moved_weight where `moved` [B, S, S] is
// 1, else 1, divided by their mean so that the weighted L1 stays on the plain L1's scale (the
// mask L1 and the prior keep their meaning). Undefined when moved_weight is 0: the plain mean.
torch::Tensor MovedLossWeights(const torch::Tensor& moved, double moved_weight);

// The mean L1 between `imagined` and `real` [B, 3, S, S], weighted per pixel by `weights` from
// MovedLossWeights (the plain mean when undefined).
torch::Tensor FrameL1(const torch::Tensor& imagined, const torch::Tensor& real,
                      const torch::Tensor& weights);

// The prior's weight at `step`: train.motion_prior fading linearly to 0 over the first
// train.motion_prior_steps of the steps, 0 after (the rest of training is the plain recipe).
double MotionPriorWeight(const TrainConfig& train, int64_t step);

}  // namespace wm::motion

#pragma once
// The action-conditioned warp predictor (docs/motion.md), in the spirit of STP/CDNA (Finn et al.
// 2016): a small U-Net reads the current and the previous frame and predicts, per pixel, where
// the next frame's pixel comes from in the current one (a backward flow), a correction image and
// a gate between the two:
//
//   next = (1 - gate) * warp(current, flow) + gate * tanh(rgb)
//   flow = flow_scale * (b + sum_i J_i * a_i)      (model.action_jacobian; else flow = b)
//
// b, J_i, rgb and the gate logit are the head's output maps; a is the normalised action. The
// flow is linear in the action with image-dependent coefficients: the U-Net finds the arm and
// its depth, the action says how far it goes, and reversing the action reverses the motion.
// The head starts at zero: an untrained model copies the current frame. Internal (includes
// torch); the torch-free API is motion/motion_model.h.
#include <torch/torch.h>

#include "motion/config.h"

namespace wm::motion {

struct WarpStep {
  torch::Tensor next;  // [B, 3, S, S]
  torch::Tensor flow;  // [B, 2, S, S] in pixels: next(p) samples current(p + flow(p))
  torch::Tensor gate;  // [B, 1, S, S] in (0, 1)
};

class WarpNetImpl : public torch::nn::Module {
 public:
  WarpNetImpl(const ModelConfig& config, int64_t action_dim);

  // current, previous: [B, 3, S, S] in [-1, 1] (previous = current at an episode's first
  // frame); action: [B, D] normalised (trainkit::ActionNorm).
  WarpStep forward(const torch::Tensor& current, const torch::Tensor& previous,
                   const torch::Tensor& action);

  int64_t action_dim() const { return action_dim_; }

 private:
  ModelConfig config_;
  int64_t action_dim_;
  torch::nn::Sequential down1{nullptr}, down2{nullptr}, down3{nullptr}, middle{nullptr};
  torch::nn::Sequential up3{nullptr}, up2{nullptr}, up1{nullptr};
  torch::nn::Linear action_in{nullptr};
  torch::nn::Conv2d head{nullptr};
};
TORCH_MODULE(WarpNet);

// out(p) = image(p + flow(p)): bilinear, pixel centres at integer coordinates, border pixels
// repeated outside the frame. image [B, C, H, W], flow [B, 2, H, W] (x then y, in pixels).
torch::Tensor Warp(const torch::Tensor& image, const torch::Tensor& flow);

}  // namespace wm::motion

#pragma once
// The layered motion model (model.kind: layers; docs/motion.md, "Layers that move as wholes"):
// the start frame is cut once into K soft layers over a static background, and each layer moves
// as a whole, by one affine map per step that is linear in the action:
//
//   masks m_k, fill = U-Net(first)                        on the start frame's pixels
//   inc_k,t = b_k + sum_i J_k,i a_t,i                     b, J from a small CNN over
//                                                         (current imagined frame, first, maps)
//   A_k,t+1 = Increment(inc_k,t about the layer's centroid) A_k,t,   A_k,0 = identity
//   frame_t = the layers (first * m_k, m_k) resampled once through A_k,t^-1, composited front
//             (k = 0) to back over  v * first + (1 - v) * fill,  v = prod_k (1 - m_k)
//
// A per-pixel backward flow linear in the action (WarpNet) cannot switch between "the arm
// arrives here" and "the table stays" at the arm's edge, and resamples the last imagined frame
// every step: the arm smears. Here each imagined frame samples the start frame once, and a
// layer's edge is as sharp as its mask. Masks are pushed to 0 or 1 in training by noise on
// their logits (train.mask_noise) and kept off what need not move by an L1 (train.mask_l1).
// Both heads start at zero: the untrained model moves nothing. Internal (includes torch).
#include <torch/torch.h>

#include "motion/config.h"

namespace wm::motion {

// Values per layer and step: the linear part about the centroid (4, row-major), then the
// translation (2, pixels).
inline constexpr int64_t kAffineParams = 6;

struct Sprites {
  torch::Tensor masks;  // [B, K, S, S] in (0, 1), on the start frame's pixels
  torch::Tensor fill;   // [B, 3, S, S] in (-1, 1): what lies behind the layers
};

// One open-loop rollout's state: the start frame's layers and where they are now.
struct LayerRollout {
  torch::Tensor first;  // [B, 3, S, S]
  Sprites sprites;
  torch::Tensor centre0;  // [B, K, 2] the masks' centroids (x, y) on the start frame
  torch::Tensor maps;     // [B, K, 3, 3] start-frame pixel -> current-frame pixel
  torch::Tensor current;  // [B, 3, S, S] the last frame (the start frame at first)
};

class LayerNetImpl : public torch::nn::Module {
 public:
  LayerNetImpl(const ModelConfig& config, int64_t action_dim);

  // `mask_noise` (training only): [B, K, S, S] added to the mask logits, or undefined.
  Sprites sprites(const torch::Tensor& first, const torch::Tensor& mask_noise = {});
  // [B, K, 6] this step's increments for the layers at `maps`, read from `current` (imagined,
  // gradient stopped) and `first`; `action` [B, D] normalised.
  torch::Tensor increments(const torch::Tensor& current, const torch::Tensor& first,
                           const torch::Tensor& maps, const torch::Tensor& action);

  LayerRollout Start(const torch::Tensor& first, const torch::Tensor& mask_noise = {});
  // The next frame [B, 3, S, S] under `action`; advances `r`.
  torch::Tensor Advance(LayerRollout& r, const torch::Tensor& action);

  int64_t action_dim() const { return action_dim_; }
  int64_t layers() const { return layers_; }

 private:
  ModelConfig config_;
  int64_t action_dim_, layers_;
  torch::nn::Sequential down1{nullptr}, down2{nullptr}, down3{nullptr}, middle{nullptr};
  torch::nn::Sequential up3{nullptr}, up2{nullptr}, up1{nullptr};
  torch::nn::Conv2d sprite_head{nullptr};
  torch::nn::Sequential motion_cnn{nullptr}, motion_mlp{nullptr};
  torch::nn::Linear motion_head{nullptr};
};
TORCH_MODULE(LayerNet);

// [B, K, S, S] -> [B, K, 2]: mask-weighted mean pixel (x, y).
torch::Tensor Centroids(const torch::Tensor& masks);
// [B, K, 3, 3] affine maps applied to [B, K, 2] points.
torch::Tensor ApplyMaps(const torch::Tensor& maps, const torch::Tensor& points);
// [B, K, 6] increments about [B, K, 2] centres -> [B, K, 3, 3]: p' = c + L (p - c) + t.
torch::Tensor IncrementMaps(const torch::Tensor& increments, const torch::Tensor& centres);
// The layers of `first` moved by `maps`, composited front to back over the background.
torch::Tensor RenderLayers(const torch::Tensor& first, const Sprites& sprites,
                           const torch::Tensor& maps);

}  // namespace wm::motion

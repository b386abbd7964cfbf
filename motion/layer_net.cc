#include "motion/layer_net.h"

#include "motion/unet_blocks.h"

namespace wm::motion {
namespace {

namespace nn = torch::nn;

// The linear part of a step's increment is bounded (|entry| < 0.2): no step shrinks or shears a
// layer to a singular map, whatever the action.
constexpr double kMaxLinearStep = 0.2;
// The layers' maps enter the motion MLP scaled down, next to ReLU features of order 1.
constexpr double kMapInputScale = 0.05;
constexpr int64_t kMotionHidden = 256;

}  // namespace

LayerNetImpl::LayerNetImpl(const ModelConfig& config, int64_t action_dim)
    : config_(config), action_dim_(action_dim), layers_(config.layers) {
  const int64_t c = config.channels, k = layers_;
  down1 = register_module("down1", Down(3, c));  // S/2
  down2 = register_module("down2", Down(c, c));  // S/4
  down3 = register_module("down3", Down(c, c));  // S/8
  middle = register_module("middle", nn::Sequential(Conv3x3(c, c), nn::ReLU()));
  up3 = register_module("up3", Up(c, c));
  up2 = register_module("up2", Up(2 * c, c));
  up1 = register_module("up1", Up(2 * c, c));
  sprite_head = register_module("sprite_head", Conv3x3(c + 3, k + 3));  // mask logits, fill
  // Four halvings: the motion CNN's map is (S / 16)^2 cells, flattened so the MLP knows where
  // things are.
  motion_cnn = register_module("motion_cnn", Downs(6, c, 4));
  const int64_t cells = (config.image_size / 16) * (config.image_size / 16);
  motion_mlp = register_module(
      "motion_mlp",
      nn::Sequential(nn::Linear(cells * c + k * kAffineParams, kMotionHidden), nn::ReLU()));
  motion_head = register_module("motion_head",
                                nn::Linear(kMotionHidden, k * kAffineParams * (action_dim + 1)));
  torch::NoGradGuard no_grad;  // zero heads: masks at 0.5, fill 0, every layer still
  for (torch::Tensor t :
       {sprite_head->weight, sprite_head->bias, motion_head->weight, motion_head->bias})
    t.zero_();
}

Sprites LayerNetImpl::sprites(const torch::Tensor& first, const torch::Tensor& mask_noise) {
  const torch::Tensor h1 = down1->forward(first);
  const torch::Tensor h2 = down2->forward(h1);
  torch::Tensor u = up3->forward(middle->forward(down3->forward(h2)));
  u = up1->forward(torch::cat({up2->forward(torch::cat({u, h2}, 1)), h1}, 1));
  const torch::Tensor out = sprite_head->forward(torch::cat({u, first}, 1));
  torch::Tensor logits = out.slice(1, 0, layers_);
  // Noisy logits pay off only where the mask is saturated: masks end up 0 or 1, so a layer is
  // drawn solid or not at all instead of as a translucent hedge.
  if (mask_noise.defined()) logits = logits + mask_noise;
  return {torch::sigmoid(logits), torch::tanh(out.slice(1, layers_))};
}

torch::Tensor LayerNetImpl::increments(const torch::Tensor& current, const torch::Tensor& first,
                                       const torch::Tensor& maps, const torch::Tensor& action) {
  const int64_t B = current.size(0), K = layers_, D = action_dim_;
  const torch::Tensor features = motion_cnn->forward(torch::cat({current, first}, 1)).flatten(1);
  const torch::Tensor eye = torch::eye(3, maps.options()).slice(0, 0, 2);
  const torch::Tensor where = (maps.slice(2, 0, 2) - eye).flatten(1) * kMapInputScale;
  const torch::Tensor out =
      motion_head->forward(motion_mlp->forward(torch::cat({features, where}, 1)))
          .view({B, K, kAffineParams, D + 1});
  const torch::Tensor inc =
      out.select(-1, 0) + (out.slice(-1, 1) * action.view({B, 1, 1, D})).sum(-1);
  return torch::cat(
      {kMaxLinearStep * torch::tanh(inc.slice(-1, 0, 4)), inc.slice(-1, 4) * config_.flow_scale},
      -1);
}

LayerRollout LayerNetImpl::Start(const torch::Tensor& first, const torch::Tensor& mask_noise) {
  LayerRollout r;
  r.first = first;
  r.sprites = sprites(first, mask_noise);
  r.centre0 = Centroids(r.sprites.masks);
  r.maps = torch::eye(3, first.options()).expand({first.size(0), layers_, 3, 3});
  r.current = first;
  return r;
}

torch::Tensor LayerNetImpl::Advance(LayerRollout& r, const torch::Tensor& action) {
  const torch::Tensor inc = increments(r.current.detach(), r.first, r.maps, action);
  r.maps = IncrementMaps(inc, ApplyMaps(r.maps, r.centre0)).matmul(r.maps);
  r.current = RenderLayers(r.first, r.sprites, r.maps);
  return r.current;
}

torch::Tensor Centroids(const torch::Tensor& masks) {
  const torch::Tensor grid = torch::arange(masks.size(-1), masks.options());
  const torch::Tensor weight = masks.sum({2, 3}) + 1e-6;
  const torch::Tensor x = (masks.sum(2) * grid).sum(-1) / weight;
  const torch::Tensor y = (masks.sum(3) * grid).sum(-1) / weight;
  return torch::stack({x, y}, -1);
}

torch::Tensor ApplyMaps(const torch::Tensor& maps, const torch::Tensor& points) {
  const torch::Tensor linear = maps.slice(-2, 0, 2).slice(-1, 0, 2);
  return linear.matmul(points.unsqueeze(-1)).squeeze(-1) + maps.slice(-2, 0, 2).select(-1, 2);
}

torch::Tensor IncrementMaps(const torch::Tensor& increments, const torch::Tensor& centres) {
  const int64_t B = increments.size(0), K = increments.size(1);
  const torch::Tensor linear =
      torch::eye(2, increments.options()) + increments.slice(-1, 0, 4).view({B, K, 2, 2});
  const torch::Tensor shift =
      centres + increments.slice(-1, 4) - linear.matmul(centres.unsqueeze(-1)).squeeze(-1);
  const torch::Tensor bottom =
      torch::tensor({0.0, 0.0, 1.0}, increments.options()).expand({B, K, 1, 3});
  return torch::cat({torch::cat({linear, shift.unsqueeze(-1)}, -1), bottom}, -2);
}

torch::Tensor RenderLayers(const torch::Tensor& first, const Sprites& sprites,
                           const torch::Tensor& maps) {
  const int64_t B = first.size(0), K = sprites.masks.size(1), S = first.size(-1);
  // Backward sampling: each imagined pixel looks up where it was on the start frame.
  const torch::Tensor to_source = torch::inverse(maps);
  const torch::Tensor coords = torch::arange(S, first.options());
  const std::vector<torch::Tensor> yx = torch::meshgrid({coords, coords}, "ij");
  const torch::Tensor pixels =
      torch::stack({yx[1], yx[0], torch::ones_like(yx[0])}, -1).view({1, 1, S * S, 3});
  // grid_sample's coordinates with align_corners: -1 and 1 are the corner pixels' centres.
  const torch::Tensor grid =
      (pixels.matmul(to_source.transpose(-1, -2)).slice(-1, 0, 2) / static_cast<double>(S - 1) * 2 -
       1)
          .view({B * K, S, S, 2});
  const torch::Tensor masks = sprites.masks.unsqueeze(2);
  const torch::Tensor layer = torch::cat({first.unsqueeze(1) * masks, masks}, 2);
  namespace F = torch::nn::functional;
  const torch::Tensor moved = F::grid_sample(layer.view({B * K, 4, S, S}), grid,
                                             F::GridSampleFuncOptions()
                                                 .mode(torch::kBilinear)
                                                 .padding_mode(torch::kBorder)
                                                 .align_corners(true))
                                  .view({B, K, 4, S, S});
  const torch::Tensor visible = torch::prod(1 - sprites.masks, 1, /*keepdim=*/true);
  torch::Tensor out = visible * first + (1 - visible) * sprites.fill;
  for (int64_t k = K - 1; k >= 0; --k) {
    const torch::Tensor layer_k = moved.select(1, k);
    out = layer_k.slice(1, 0, 3) + (1 - layer_k.slice(1, 3)) * out;
  }
  return out;
}

}  // namespace wm::motion

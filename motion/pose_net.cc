#include "motion/pose_net.h"

#include "motion/unet_blocks.h"
#include "motion/warp_net.h"

namespace wm::motion {
namespace {

namespace nn = torch::nn;

constexpr int64_t kEncoderHidden = 256, kDynamicsHidden = 128;
// The renderer's alpha logit at the start: sigmoid(-2) = 0.12, drawn faintly everywhere, so the
// pose gets gradients from the first step (at -3 with an L1 loss the alpha died: measured).
constexpr double kAlphaBias = -2;
// The shade logit at the start: sigmoid(2) = 0.88, the background nearly lit everywhere but the
// shade's gradient not yet saturated.
constexpr double kShadeBias = 2;

// [1, 2, S, S]: each pixel's x and y in [-1, 1].
torch::Tensor Coordinates(int64_t size, const torch::TensorOptions& options) {
  const torch::Tensor grid = torch::linspace(-1, 1, size, options);
  const std::vector<torch::Tensor> yx = torch::meshgrid({grid, grid}, "ij");
  return torch::stack({yx[1], yx[0]}).unsqueeze(0);
}

// The parameters of `net` under "dynamics." (or all the others).
std::vector<std::pair<std::string, torch::Tensor>> ParametersOf(const torch::nn::Module& net,
                                                                bool dynamics) {
  std::vector<std::pair<std::string, torch::Tensor>> out;
  for (const auto& item : net.named_parameters())
    if ((item.key().rfind("dynamics.", 0) == 0) == dynamics)
      out.emplace_back(item.key(), item.value());
  return out;
}

// Four (nearest x2, 3x3 convolution, ReLU) stages of width, width / 2, width / 4, width / 4 from
// a map at S / 16, then a 3x3 convolution to `outputs` channels (`*last`).
nn::Sequential UpsamplingStages(int64_t width, int64_t outputs, nn::Conv2d* last) {
  const int64_t widths[] = {width, width, width / 2, width / 4, width / 4};
  nn::Sequential stages;
  for (int i = 0; i < 4; ++i) {
    stages->push_back(nn::Upsample(
        nn::UpsampleOptions().scale_factor(std::vector<double>{2, 2}).mode(torch::kNearest)));
    stages->push_back(Conv3x3(widths[i], widths[i + 1]));
    stages->push_back(nn::ReLU());
  }
  *last = Conv3x3(widths[4], outputs);
  stages->push_back(*last);
  return stages;
}

}  // namespace

PoseEncoderImpl::PoseEncoderImpl(int64_t pose_dim, int64_t channels, int64_t image_size) {
  const int64_t cells = (image_size / 16) * (image_size / 16);
  cnn = register_module("cnn", Downs(5, channels, 4));
  head = register_module("head", nn::Sequential(nn::Linear(cells * channels, kEncoderHidden),
                                                nn::ReLU(), nn::Linear(kEncoderHidden, pose_dim)));
}

torch::Tensor PoseEncoderImpl::forward(const torch::Tensor& frames) {
  const torch::Tensor grid =
      Coordinates(frames.size(-1), frames.options()).expand({frames.size(0), 2, -1, -1});
  return head->forward(cnn->forward(torch::cat({frames, grid}, 1)).flatten(1));
}

DeconvRendererImpl::DeconvRendererImpl(int64_t pose_dim, int64_t width, int64_t image_size,
                                       bool shade)
    : start_(image_size / 16), width_(width), shade_(shade) {
  fc = register_module("fc", nn::Linear(pose_dim, width * start_ * start_));
  nn::Conv2d out{nullptr};
  up = register_module("up", UpsamplingStages(width, shade ? 5 : 4, &out));
  torch::NoGradGuard no_grad;
  out->bias.slice(0, 3, 4).fill_(kAlphaBias);
  if (shade) out->bias.slice(0, 4, 5).fill_(kShadeBias);
}

Drawn DeconvRendererImpl::forward(const torch::Tensor& pose) {
  const torch::Tensor x = torch::relu(fc->forward(pose)).view({-1, width_, start_, start_});
  const torch::Tensor out = up->forward(x);
  Drawn drawn{torch::tanh(out.slice(1, 0, 3)), torch::sigmoid(out.slice(1, 3, 4)), {}};
  if (shade_) drawn.shade = torch::sigmoid(out.slice(1, 4, 5));
  return drawn;
}

PoseMoverImpl::PoseMoverImpl(int64_t pose_dim, int64_t width, int64_t image_size,
                             double flow_scale)
    : pose_dim_(pose_dim), start_(image_size / 16), width_(width), flow_scale_(flow_scale) {
  fc = register_module("fc", nn::Linear(pose_dim, width * start_ * start_));
  nn::Conv2d out{nullptr};
  up = register_module("up", UpsamplingStages(width, 2 * pose_dim, &out));
  torch::NoGradGuard no_grad;
  out->weight.zero_();
  out->bias.zero_();
}

torch::Tensor PoseMoverImpl::forward(const torch::Tensor& start_pose, const torch::Tensor& pose) {
  const torch::Tensor x = torch::relu(fc->forward(start_pose)).view({-1, width_, start_, start_});
  const torch::Tensor jacobian = up->forward(x);  // [B, 2 P, S, S]: x's P maps, then y's
  const int64_t B = jacobian.size(0), S = jacobian.size(-1);
  const torch::Tensor change = (pose - start_pose).view({B, 1, pose_dim_, 1, 1});
  return flow_scale_ * (jacobian.view({B, 2, pose_dim_, S, S}) * change).sum(2);
}

PoseDynamicsImpl::PoseDynamicsImpl(int64_t pose_dim, int64_t action_dim) {
  action_map = register_module("action_map",
                               nn::Linear(nn::LinearOptions(action_dim, pose_dim).bias(false)));
  nn::Linear last(kDynamicsHidden, pose_dim);
  correction = register_module(
      "correction", nn::Sequential(nn::Linear(pose_dim + action_dim, kDynamicsHidden), nn::ReLU(),
                                   nn::Linear(kDynamicsHidden, kDynamicsHidden), nn::ReLU(), last));
  torch::NoGradGuard no_grad;  // the correction starts at zero: the pose moves linearly
  last->weight.zero_();
  last->bias.zero_();
}

torch::Tensor PoseDynamicsImpl::forward(const torch::Tensor& pose, const torch::Tensor& action) {
  return pose + action_map->forward(action) + correction->forward(torch::cat({pose, action}, 1));
}

PoseNetImpl::PoseNetImpl(const ModelConfig& config, int64_t action_dim) {
  encoder_ =
      register_module("encoder", PoseEncoder(config.pose_dim, config.channels, config.image_size));
  renderer_ = register_module(
      "renderer", DeconvRenderer(config.pose_dim, config.renderer_width, config.image_size,
                                 config.renderer_shade));
  ModelConfig one_layer = config;
  one_layer.layers = 1;
  eraser_ = register_module("eraser", LayerNet(one_layer, /*action_dim=*/1));
  dynamics_ = register_module("dynamics", PoseDynamics(config.pose_dim, action_dim));
  if (config.renderer_warp)
    mover_ = register_module("mover", PoseMover(config.pose_dim, config.renderer_width,
                                                config.image_size, config.flow_scale));
}

torch::Tensor PoseNetImpl::Background(const torch::Tensor& frames) {
  const Sprites s = eraser_->sprites(frames);
  return frames * (1 - s.masks) + s.fill * s.masks;
}

PoseRollout PoseNetImpl::Start(const torch::Tensor& first) {
  const Sprites s = eraser_->sprites(first);
  PoseRollout r{.background = first * (1 - s.masks) + s.fill * s.masks,
                .pose = encoder_->forward(first)};
  if (mover_) {
    r.moving = torch::cat({first * s.masks, s.masks}, 1);
    r.start_pose = r.pose;
  }
  return r;
}

PoseFrame PoseNetImpl::Draw(const PoseRollout& r) {
  torch::Tensor under = r.background;
  if (mover_) {  // premultiplied: the moved colour x mask, then the moved mask
    const torch::Tensor moved = Warp(r.moving, mover_->forward(r.start_pose, r.pose));
    under = moved.slice(1, 0, 3) + (1 - moved.slice(1, 3)) * r.background;
  }
  PoseFrame out{.drawn = renderer_->forward(r.pose)};
  out.frame = out.drawn.Over(under);
  return out;
}

torch::Tensor PoseNetImpl::Advance(PoseRollout& r, const torch::Tensor& action) {
  r.pose = dynamics_->forward(r.pose, action);
  return Draw(r).frame;
}

std::vector<std::pair<std::string, torch::Tensor>> PoseNetImpl::AutoencoderParameters() const {
  return ParametersOf(*this, /*dynamics=*/false);
}

std::vector<std::pair<std::string, torch::Tensor>> PoseNetImpl::DynamicsParameters() const {
  return ParametersOf(*this, /*dynamics=*/true);
}

}  // namespace wm::motion

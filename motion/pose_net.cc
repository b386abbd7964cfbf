#include "motion/pose_net.h"

#include "motion/unet_blocks.h"

namespace wm::motion {
namespace {

namespace nn = torch::nn;

constexpr int64_t kEncoderHidden = 256;
// The renderer's alpha logit at the start: sigmoid(-2) = 0.12, drawn faintly everywhere, so the
// pose gets gradients from the first step (at -3 with an L1 loss the alpha died: measured).
constexpr double kAlphaBias = -2;

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

DeconvRendererImpl::DeconvRendererImpl(int64_t pose_dim, int64_t width, int64_t image_size)
    : start_(image_size / 16), width_(width) {
  fc = register_module("fc", nn::Linear(pose_dim, width * start_ * start_));
  const int64_t widths[] = {width, width, width / 2, width / 4, width / 4};
  nn::Sequential stages;
  for (int i = 0; i < 4; ++i) {
    stages->push_back(nn::Upsample(
        nn::UpsampleOptions().scale_factor(std::vector<double>{2, 2}).mode(torch::kNearest)));
    stages->push_back(Conv3x3(widths[i], widths[i + 1]));
    stages->push_back(nn::ReLU());
  }
  out_ = Conv3x3(widths[4], 4);
  stages->push_back(out_);
  up = register_module("up", stages);
  torch::NoGradGuard no_grad;
  out_->bias.slice(0, 3).fill_(kAlphaBias);
}

Drawn DeconvRendererImpl::Logits(const torch::Tensor& pose) {
  const torch::Tensor x = torch::relu(fc->forward(pose)).view({-1, width_, start_, start_});
  const torch::Tensor out = up->forward(x);
  return {torch::tanh(out.slice(1, 0, 3)), out.slice(1, 3)};
}

Drawn DeconvRendererImpl::forward(const torch::Tensor& pose) {
  const Drawn drawn = Logits(pose);
  return {drawn.rgb, torch::sigmoid(drawn.alpha)};
}

void DeconvRendererImpl::ShiftAlpha(double shift) {
  torch::NoGradGuard no_grad;
  out_->bias.slice(0, 3).add_(shift);
}

PoseDynamicsImpl::PoseDynamicsImpl(int64_t pose_dim, int64_t action_dim, int64_t hidden) {
  action_map = register_module("action_map",
                               nn::Linear(nn::LinearOptions(action_dim, pose_dim).bias(false)));
  nn::Linear last(hidden, pose_dim);
  correction = register_module(
      "correction", nn::Sequential(nn::Linear(pose_dim + action_dim, hidden), nn::ReLU(),
                                   nn::Linear(hidden, hidden), nn::ReLU(), last));
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
      "renderer", DeconvRenderer(config.pose_dim, config.renderer_width, config.image_size));
  ModelConfig one_layer = config;
  one_layer.layers = 1;
  eraser_ = register_module("eraser", LayerNet(one_layer, /*action_dim=*/1));
  dynamics_ = register_module(
      "dynamics", PoseDynamics(config.pose_dim, action_dim, config.dynamics_hidden));
}

torch::Tensor PoseNetImpl::Background(const torch::Tensor& frames) {
  const Sprites s = eraser_->sprites(frames);
  return frames * (1 - s.masks) + s.fill * s.masks;
}

PoseRollout PoseNetImpl::Start(const torch::Tensor& first) {
  return {.background = Background(first), .pose = encoder_->forward(first)};
}

torch::Tensor PoseNetImpl::Advance(PoseRollout& r, const torch::Tensor& action) {
  r.pose = dynamics_->forward(r.pose, action);
  return renderer_->forward(r.pose).Over(r.background);
}

std::vector<std::pair<std::string, torch::Tensor>> PoseNetImpl::AutoencoderParameters() const {
  return ParametersOf(*this, /*dynamics=*/false);
}

std::vector<std::pair<std::string, torch::Tensor>> PoseNetImpl::DynamicsParameters() const {
  return ParametersOf(*this, /*dynamics=*/true);
}

}  // namespace wm::motion

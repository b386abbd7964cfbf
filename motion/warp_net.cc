#include "motion/warp_net.h"

#include "motion/unet_blocks.h"

namespace wm::motion {
namespace {

namespace nn = torch::nn;

// Head channels: rgb (3), gate logit (1), flow bias (2), then with model.action_jacobian the
// flow per action value, x rows then y rows (2 * D).
constexpr int64_t kRgb = 0, kGate = 3, kFlowBias = 4, kJacobian = 6;

}  // namespace

WarpNetImpl::WarpNetImpl(const ModelConfig& config, int64_t action_dim)
    : config_(config), action_dim_(action_dim) {
  const int64_t c = config.channels;
  down1 = register_module("down1", Down(6, c));  // S/2
  down2 = register_module("down2", Down(c, c));  // S/4
  down3 = register_module("down3", Down(c, c));  // S/8
  action_in = register_module("action_in", nn::Linear(action_dim, c));
  middle = register_module("middle",
                           nn::Sequential(Conv3x3(c, c), nn::ReLU(), Conv3x3(c, c), nn::ReLU()));
  up3 = register_module("up3", Up(c, c));
  up2 = register_module("up2", Up(2 * c, c));
  up1 = register_module("up1", Up(2 * c, c));
  const int64_t outputs = kJacobian + (config.action_jacobian ? 2 * action_dim : 0);
  head = register_module("head", Conv3x3(c + 6, outputs));
  torch::NoGradGuard no_grad;  // zero head: the untrained model copies the current frame
  head->weight.zero_();
  head->bias.zero_();
}

WarpStep WarpNetImpl::forward(const torch::Tensor& current, const torch::Tensor& previous,
                              const torch::Tensor& action) {
  const torch::Tensor input = torch::cat({current, previous}, 1);
  const torch::Tensor h1 = down1->forward(input);
  const torch::Tensor h2 = down2->forward(h1);
  const torch::Tensor bottleneck =
      down3->forward(h2) + action_in->forward(action).unsqueeze(-1).unsqueeze(-1);
  torch::Tensor u = up3->forward(middle->forward(bottleneck));
  u = up1->forward(torch::cat({up2->forward(torch::cat({u, h2}, 1)), h1}, 1));
  const torch::Tensor out = head->forward(torch::cat({u, input}, 1));
  torch::Tensor flow = out.slice(1, kFlowBias, kJacobian);
  if (config_.action_jacobian) {
    const int64_t B = out.size(0), H = out.size(2), W = out.size(3);
    const torch::Tensor jacobian = out.slice(1, kJacobian).view({B, 2, action_dim_, H, W});
    flow = flow + (jacobian * action.view({B, 1, action_dim_, 1, 1})).sum(2);
  }
  flow = flow * config_.flow_scale;
  const torch::Tensor gate = torch::sigmoid(out.slice(1, kGate, kGate + 1) + config_.gate_bias);
  const torch::Tensor rgb = torch::tanh(out.slice(1, kRgb, kRgb + 3));
  return {(1 - gate) * Warp(current, flow) + gate * rgb, flow, gate};
}

torch::Tensor Warp(const torch::Tensor& image, const torch::Tensor& flow) {
  const int64_t H = image.size(2), W = image.size(3);
  const auto options = image.options();
  const torch::Tensor xs = torch::arange(W, options).view({1, 1, W});
  const torch::Tensor ys = torch::arange(H, options).view({1, H, 1});
  // grid_sample's coordinates with align_corners: -1 and 1 are the corner pixels' centres.
  const torch::Tensor gx = (xs + flow.select(1, 0)) / static_cast<double>(W - 1) * 2 - 1;
  const torch::Tensor gy = (ys + flow.select(1, 1)) / static_cast<double>(H - 1) * 2 - 1;
  namespace F = torch::nn::functional;
  return F::grid_sample(image, torch::stack({gx, gy}, -1),
                        F::GridSampleFuncOptions()
                            .mode(torch::kBilinear)
                            .padding_mode(torch::kBorder)
                            .align_corners(true));
}

}  // namespace wm::motion

#include "success/success_net.h"

namespace wm::success {
namespace {

namespace nn = torch::nn;

nn::Conv2d Conv(int64_t in, int64_t out, int64_t kernel, int64_t stride) {
  return nn::Conv2d(nn::Conv2dOptions(in, out, kernel).stride(stride).padding(1));
}

}  // namespace

SuccessNetImpl::SuccessNetImpl(const ModelConfig& c) {
  const int64_t C = c.channels;
  features = register_module(
      "features", nn::Sequential(Conv(3, C, 4, 2), nn::ReLU(),          // [B, C, S/2, S/2]
                                 Conv(C, 2 * C, 4, 2), nn::ReLU(),      // [B, 2C, S/4, S/4]
                                 Conv(2 * C, 4 * C, 4, 2), nn::ReLU(),  // [B, 4C, S/8, S/8]
                                 Conv(4 * C, 4 * C, 3, 1), nn::ReLU()));
  logit = register_module("logit", nn::Linear(8 * C, 1));
}

torch::Tensor SuccessNetImpl::forward(const torch::Tensor& frames) {
  const torch::Tensor f = features->forward(frames).flatten(2);  // [B, 4C, S*S/64]
  const torch::Tensor pooled = torch::cat({f.mean(2), std::get<0>(f.max(2))}, 1);  // [B, 8C]
  return logit->forward(pooled).squeeze(1);                                        // [B]
}

}  // namespace wm::success

#include "metrics/lpips/alexnet_trunk.h"

#include <string>

namespace wm::metrics {
namespace {

struct ConvShape {
  int64_t in, out, kernel, stride, padding;
};
constexpr std::array<ConvShape, kLpipsLayers> kConvs = {{{3, 64, 11, 4, 2},
                                                         {64, 192, 5, 1, 2},
                                                         {192, 384, 3, 1, 1},
                                                         {384, 256, 3, 1, 1},
                                                         {256, 256, 3, 1, 1}}};

}  // namespace

AlexNetTrunkImpl::AlexNetTrunkImpl() {
  for (int l = 0; l < kLpipsLayers; ++l) {
    const ConvShape& s = kConvs[l];
    convs[l] = register_module(
        "conv" + std::to_string(l + 1),
        torch::nn::Conv2d(
            torch::nn::Conv2dOptions(s.in, s.out, s.kernel).stride(s.stride).padding(s.padding)));
  }
}

void AlexNetTrunkImpl::PrepareForCpu() {
  if (!at::hasMKLDNN()) return;
  torch::NoGradGuard no_grad;
  for (torch::nn::Conv2d& conv : convs) {
    conv->weight.set_data(conv->weight.contiguous(at::MemoryFormat::ChannelsLast));
  }
  try {
    for (int l = 0; l < kLpipsLayers; ++l) {
      packed_weights_[l] = at::mkldnn_reorder_conv2d_weight(
          convs[l]->weight.detach().contiguous().to_mkldnn(),
          {kConvs[l].padding, kConvs[l].padding}, {kConvs[l].stride, kConvs[l].stride}, {1, 1}, 1);
    }
  } catch (const c10::Error&) {  // a LibTorch without this path: the dense one still works
    packed_weights_ = {};
  }
}

torch::Tensor AlexNetTrunkImpl::Convolve(int layer, const torch::Tensor& x, bool blocked) {
  if (!blocked) return convs[layer]->forward(x);
  const int64_t p = kConvs[layer].padding, s = kConvs[layer].stride;
  return at::mkldnn_convolution(x, packed_weights_[layer], convs[layer]->bias, {p, p}, {s, s},
                                {1, 1}, 1);
}

std::array<torch::Tensor, kLpipsLayers> AlexNetTrunkImpl::forward(const torch::Tensor& x) {
  const bool blocked =
      packed_weights_[0].defined() && x.is_cpu() && x.size(2) * x.size(3) <= kBlockedMaxPixels;
  std::array<torch::Tensor, kLpipsLayers> relu;
  relu[0] = Convolve(0, blocked ? x.to_mkldnn() : x, blocked).relu_();  // [N, 64, H1, W1]
  torch::Tensor h = torch::max_pool2d(relu[0], {3, 3}, {2, 2});         // [N, 64, H2, W2]
  relu[1] = Convolve(1, h, blocked).relu_();                            // [N, 192, H2, W2]
  h = torch::max_pool2d(relu[1], {3, 3}, {2, 2});                       // [N, 192, H3, W3]
  relu[2] = Convolve(2, h, blocked).relu_();                            // [N, 384, H3, W3]
  relu[3] = Convolve(3, relu[2], blocked).relu_();                      // [N, 256, H3, W3]
  relu[4] = Convolve(4, relu[3], blocked).relu_();                      // [N, 256, H3, W3]
  if (blocked) {
    for (torch::Tensor& r : relu) r = r.to_dense();
  }
  return relu;
}

}  // namespace wm::metrics

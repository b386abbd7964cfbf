#pragma once
// The success classifier's network (internal: includes torch; docs/success.md, "Architecture"):
// three stride-2 convs and a 3x3 conv, then the mean and the max of the features over the image
// (the block on the goal disc is a small local pattern anywhere in the frame), then a linear
// logit of P(success | frame).
#include <torch/torch.h>

#include "success/config.h"

namespace wm::success {

class SuccessNetImpl : public torch::nn::Module {
 public:
  explicit SuccessNetImpl(const ModelConfig& config);
  // frames: [B, 3, S, S] in [-1, 1]. Returns logits [B].
  torch::Tensor forward(const torch::Tensor& frames);

 private:
  torch::nn::Sequential features{nullptr};
  torch::nn::Linear logit{nullptr};
};
TORCH_MODULE(SuccessNet);

}  // namespace wm::success

#include "trainkit/adamw.h"

#include <cmath>

namespace wm::trainkit {

AdamW::AdamW(std::vector<std::pair<std::string, torch::Tensor>> named_parameters,
             AdamWOptions options)
    : params_(std::move(named_parameters)), options_(options) {
  for (const auto& [name, p] : params_) {
    exp_avg_.push_back(torch::zeros_like(p, torch::MemoryFormat::Preserve));
    exp_avg_sq_.push_back(torch::zeros_like(p, torch::MemoryFormat::Preserve));
  }
}

void AdamW::ZeroGrad() {
  for (auto& [name, p] : params_) {
    if (p.grad().defined()) p.mutable_grad().zero_();
  }
}

// torch.optim.AdamW (torch/optim/adamw.py, _single_tensor_adamw) for one step.
void AdamW::Step() {
  torch::NoGradGuard no_grad;
  ++step_;
  const double c1 = 1.0 - std::pow(options_.beta1, static_cast<double>(step_));
  const double c2 = 1.0 - std::pow(options_.beta2, static_cast<double>(step_));
  for (size_t i = 0; i < params_.size(); ++i) {
    torch::Tensor& p = params_[i].second;
    if (!p.grad().defined()) continue;
    const torch::Tensor& g = p.grad();
    p.mul_(1.0 - options_.lr * options_.weight_decay);
    exp_avg_[i].mul_(options_.beta1).add_(g, 1.0 - options_.beta1);
    exp_avg_sq_[i].mul_(options_.beta2).addcmul_(g, g, 1.0 - options_.beta2);
    torch::Tensor denom = (exp_avg_sq_[i].sqrt() / std::sqrt(c2)).add_(options_.eps);
    p.addcdiv_(exp_avg_[i], denom, -options_.lr / c1);
  }
}

}  // namespace wm::trainkit

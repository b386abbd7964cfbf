#pragma once
// AdamW with decoupled weight decay, the same update as torch.optim.AdamW (amsgrad off).
// wmkit keeps its own because LibTorch's optimizer serialises its state keyed by tensor
// addresses, which makes checkpoint bytes differ between identical runs; here the state is
// plain tensors named after the parameters, saved in the wmkit tensor archive.
// Internal header (includes torch).
#include <torch/torch.h>

#include <string>
#include <utility>
#include <vector>

namespace wm::trainkit {

struct AdamWOptions {
  double lr = 3e-4;
  double beta1 = 0.9, beta2 = 0.9;
  double eps = 1e-8;
  double weight_decay = 1e-4;
};

class AdamW {
 public:
  AdamW(std::vector<std::pair<std::string, torch::Tensor>> named_parameters, AdamWOptions options);
  void set_lr(double lr) { options_.lr = lr; }
  void ZeroGrad();
  void Step();

  int64_t step_count() const { return step_; }
  void set_step_count(int64_t step) { step_ = step; }
  // Per parameter name: its first and second moment (created zero, on the parameter's device).
  const std::vector<std::pair<std::string, torch::Tensor>>& parameters() const { return params_; }
  std::vector<torch::Tensor>& exp_avg() { return exp_avg_; }
  std::vector<torch::Tensor>& exp_avg_sq() { return exp_avg_sq_; }
  const std::vector<torch::Tensor>& exp_avg() const { return exp_avg_; }
  const std::vector<torch::Tensor>& exp_avg_sq() const { return exp_avg_sq_; }

 private:
  std::vector<std::pair<std::string, torch::Tensor>> params_;
  std::vector<torch::Tensor> exp_avg_, exp_avg_sq_;
  AdamWOptions options_;
  int64_t step_ = 0;
};

}  // namespace wm::trainkit

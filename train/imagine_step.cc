#include "train/imagine_step.h"

#include "core/error.h"
#include "train/batch.h"

namespace wm::train {
namespace {

torch::Tensor AppendFrame(const torch::Tensor& x, const torch::Tensor& frame) {  // along axis 1
  return torch::cat({x, frame.unsqueeze(1)}, 1);
}

torch::Tensor LastFrame(const torch::Tensor& x) {  // [B, T, ...] -> [B, 1, ...]
  return x.slice(1, x.size(1) - 1, x.size(1));
}

StInput LastFrame(const StInput& in) {
  return {LastFrame(in.x), in.cond.defined() ? LastFrame(in.cond) : in.cond};
}

}  // namespace

CachedWindow::CachedWindow(WorldModel& model, const torch::Tensor& tokens,
                           const torch::Tensor& actions, const torch::Tensor& z)
    : model_(model), tokens_(tokens), actions_(actions), z_(z) {
  Check(tokens.size(1) < model->config.model.context_frames,
        "a cached window leaves a slot for the new frame");
  DynamicsNetImpl& net = *model->dynamics;
  const torch::Tensor h =
      net.transformer->ForwardCaching(net.Embed(tokens, actions, z), cache_);  // [B, Tc, N, D]
  last_output_ = LastFrame(h);
}

torch::Tensor CachedWindow::NewFrameOutput(const StInput& x) {
  // The window's frames were encoded as frames 0..Tc-1 (rotary time): the new one is frame Tc.
  return model_->dynamics->transformer->ForwardAppended(LastFrame(x), cache_,
                                                        tokens_.size(1));  // [B, 1, N, D]
}

torch::Tensor CachedWindow::LogProbs(const torch::Tensor& partial) {
  torch::NoGradGuard no_grad;
  DynamicsNetImpl& net = *model_->dynamics;
  torch::Tensor h = last_output_;  // next_frame: the last position predicts the next frame
  if (!net.next_frame()) {
    // A MaskGIT round: the partial frame at position Tc ("masked" shifts the actions and z
    // one position on, so the padding's are unused).
    auto pad = [](const torch::Tensor& x) {
      return AppendFrame(x, torch::zeros_like(x.select(1, 0)));
    };
    h = NewFrameOutput(net.Embed(AppendFrame(tokens_, partial.to(tokens_.device())), pad(actions_),
                                 z_.defined() ? pad(z_) : z_));
  }
  // Either way the new frame's copy prior points at the window's last frame.
  torch::Tensor logits = net.TokenLogits(h, LastFrame(tokens_)).select(1, 0);  // [B, N, K]
  return torch::log_softmax(logits.to(torch::kCPU, torch::kFloat), -1);
}

torch::Tensor CachedWindow::DecodeNext(int steps, double temperature,
                                       const std::vector<uint64_t>& row_seeds) {
  torch::NoGradGuard no_grad;
  const DynamicsNetImpl& net = *model_->dynamics;
  Check(static_cast<int64_t>(row_seeds.size()) == tokens_.size(0),
        "CachedWindow: one row seed per row");
  return SampleFrame([this](const torch::Tensor& partial) { return LogProbs(partial); },
                     tokens_.size(2), net.config.num_codes, net.next_frame(), steps, temperature,
                     row_seeds);
}

DynamicsOutput CachedWindow::StepReward(const torch::Tensor& tokens, const torch::Tensor& actions,
                                        const torch::Tensor& z) {
  torch::NoGradGuard no_grad;
  Check(tokens.size(1) == tokens_.size(1) + 1, "StepReward takes the window extended by a frame");
  DynamicsNetImpl& net = *model_->dynamics;
  DynamicsOutput out;
  net.RewardHead(NewFrameOutput(net.Embed(tokens, actions, z)), out);  // [B, 1] each
  out.reward = out.reward.select(1, 0);
  out.terminal_logit = out.terminal_logit.select(1, 0);
  return out;
}

}  // namespace wm::train

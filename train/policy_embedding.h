#pragma once
// The policy embedding model of WHALE Sec. 3.2 on token frames: a posterior q(z | tau_H) over the
// whole segment, a prior p(z | tau_h) over each prefix, and a Gaussian policy decoder
// pi(a_h | o_h, tau_{h-1}, z). z is `categories` one-hot variables of `classes` classes each,
// sampled with the straight-through estimator. The three networks share one token embedding.
// Internal header (includes torch).
#include <torch/torch.h>

#include "train/config.h"
#include "train/st_transformer.h"

namespace wm::train {

struct PolicyOutput {
  torch::Tensor posterior_logits;  // [B, C, K] of q(z | tau_H)
  torch::Tensor prior_logits;      // [B, T, C, K] of p(z | tau_h), h = 0..T-1
  torch::Tensor z;                 // [B, C*K] straight-through sample of q (forward: one-hot)
  torch::Tensor action_mean;       // [B, T, D] of pi(a_h | ...), D = model.action_dim
  torch::Tensor action_log_std;    // [B, T, D], clamped to [log_std_min, log_std_max]
};

struct PolicyLosses {
  torch::Tensor nll;   // -sum_h log pi(a_h | ...), mean over the batch (WHALE eq. 4, first term)
  torch::Tensor kl;    // sum_h KL(q || p_h), mean over the batch (eq. 4, second term)
  torch::Tensor loss;  // nll + kl_beta * kl
};

// One-hot sample of softmax(logits) along the last axis, chosen by Gumbel-max with the given
// uniform noise `u` (same shape, in (0, 1)), with straight-through gradients:
// forward = one_hot, backward = d softmax(logits).
torch::Tensor StraightThroughSample(const torch::Tensor& logits, const torch::Tensor& u);

// sum over categories of KL(Cat(q) || Cat(p)) from logits [..., C, K] -> [...].
torch::Tensor CategoricalKl(const torch::Tensor& q_logits, const torch::Tensor& p_logits);

// -log N(a; mean, exp(log_std)) summed over the last axis: [..., A] -> [...]. With `mask`
// (broadcastable to [..., A], 1 = a real value, 0 = padding), only the real dimensions count.
torch::Tensor GaussianNll(const torch::Tensor& a, const torch::Tensor& mean,
                          const torch::Tensor& log_std, const torch::Tensor& mask = {});

struct PolicyEmbeddingImpl : torch::nn::Module {
  PolicyEmbeddingImpl(const ModelConfig& model, const PolicyConfig& policy);

  // tokens [B, T, N] int64 (no mask tokens), actions [B, T, D] normalised (padding zeroed),
  // noise [B, C, K] uniform for the posterior sample.
  PolicyOutput forward(const torch::Tensor& tokens, const torch::Tensor& actions,
                       const torch::Tensor& noise);
  // Only the prior: [B, T, C, K] logits; what the dynamics model is conditioned on.
  torch::Tensor Prior(const torch::Tensor& tokens, const torch::Tensor& actions);
  // `action_mask` [B, 1, D] (undefined = every dimension real): padding stays out of the NLL.
  PolicyLosses Losses(const PolicyOutput& out, const torch::Tensor& actions,
                      const torch::Tensor& action_mask = {}) const;

  // token + spatial + temporal embedding (+ `extra` [B, T, D] per frame): [B, T, N, Dp].
  torch::Tensor Embed(const torch::Tensor& tokens, const torch::Tensor& extra);

  PolicyConfig config;
  torch::nn::Embedding token_embed{nullptr};
  torch::Tensor spatial_pos, temporal_pos;  // [N, Dp], [T, Dp]
  torch::nn::Linear posterior_action{nullptr}, prior_action{nullptr};
  torch::nn::Linear decoder_prev_action{nullptr}, decoder_z{nullptr};
  torch::Tensor decoder_start;  // [Dp]: stands for a_{-1} at h = 0
  StTransformer posterior{nullptr}, prior{nullptr}, decoder{nullptr};
  torch::nn::Linear posterior_head{nullptr}, prior_head{nullptr}, decoder_head{nullptr};
};
TORCH_MODULE(PolicyEmbedding);

}  // namespace wm::train

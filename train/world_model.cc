#include "train/world_model.h"

#include <numbers>

namespace wm::train {
namespace F = torch::nn::functional;

torch::Tensor CosineMaskRatio(const torch::Tensor& r) {
  return torch::cos(r * (std::numbers::pi / 2));
}

torch::Tensor TrainingMask(const torch::Tensor& u_ratio, const torch::Tensor& u_order,
                           const torch::Tensor& u_frame, double frame_prob) {
  const int64_t N = u_order.size(2), T = u_order.size(1);
  torch::Tensor count = torch::ceil(CosineMaskRatio(u_ratio) * N).clamp(1, N);  // [B, T]
  torch::Tensor target = u_frame < frame_prob;                                  // [B, T]
  target.select(1, 0).fill_(false);  // frame 0 is the given observation
  // Clean context frames teach the model to use a clean history, as at inference.
  target.select(1, T - 1).logical_or_(target.any(1).logical_not());
  torch::Tensor rank = torch::argsort(torch::argsort(u_order, -1, false), -1, false);  // [B,T,N]
  return (rank < count.unsqueeze(-1)).logical_and_(target.unsqueeze(-1));              // [B, T, N]
}

DynamicsNetImpl::DynamicsNetImpl(const ModelConfig& m, int64_t z_dim) : config(m), z_dim(z_dim) {
  const int64_t d = m.d_model, N = int64_t{m.grid_h} * m.grid_w;
  token_embed = register_module("token_embed", torch::nn::Embedding(m.num_codes + 1, d));
  spatial_pos = register_parameter("spatial_pos", torch::randn({N, d}) * 0.02);
  temporal_pos = register_parameter("temporal_pos", torch::randn({m.context_frames, d}) * 0.02);
  action_start = register_parameter("action_start", torch::randn({d}) * 0.02);
  action_in = register_module("action_in", torch::nn::Linear(kActionDim, d));
  if (z_dim > 0) z_in = register_module("z_in", torch::nn::Linear(z_dim, d));
  transformer =
      register_module("transformer", StTransformer(StBlockOptions{.dim = d,
                                                                  .heads = m.num_heads,
                                                                  .mlp_ratio = m.mlp_ratio,
                                                                  .rms_norm = m.norm == "rmsnorm",
                                                                  .causal_time = true},
                                                   m.num_layers));
  if (m.tied_token_head) {
    token_bias = register_parameter("token_bias", torch::zeros({m.num_codes}));
  } else {
    token_head = register_module("token_head", torch::nn::Linear(d, m.num_codes));
  }
  reward_head = register_module("reward_head", torch::nn::Linear(d, 2));
  InitWeights(*this);
}

DynamicsOutput DynamicsNetImpl::forward(const torch::Tensor& tokens, const torch::Tensor& actions,
                                        const torch::Tensor& z) {
  const int64_t B = tokens.size(0), T = tokens.size(1);
  // Position j carries a_{j-1} and z_{j-1} (eq. 5: x_{h+1} | x_{1:h}, a_{1:h}, z_h).
  torch::Tensor past = actions.slice(1, 0, T - 1);
  // The action-blind control sees zeros: same parameters, no information in the actions.
  if (!config.action_conditioning) past = torch::zeros_like(past);
  torch::Tensor cond =
      torch::cat({action_start.expand({B, 1, -1}), action_in->forward(past)}, 1);  // [B, T, D]
  if (z_dim > 0) {
    torch::Tensor zc = z_in->forward(z.slice(1, 0, T - 1));     // [B, T-1, D]
    cond = cond + F::pad(zc, F::PadFuncOptions({0, 0, 1, 0}));  // [B, T, D]
  }
  torch::Tensor x = token_embed->forward(tokens) + spatial_pos +  // [B, T, N, D]
                    (temporal_pos.slice(0, 0, T) + cond).unsqueeze(2);
  torch::Tensor h = transformer->forward(x);  // [B, T, N, D]
  DynamicsOutput out;
  out.logits = token_head ? token_head->forward(h)  // [B, T, N, K]
                          : F::linear(h, token_embed->weight.slice(0, 0, config.num_codes),
                                      token_bias);
  auto rt = reward_head->forward(h.mean(2)).unbind(-1);  // 2x [B, T]
  out.reward = rt[0];
  out.terminal_logit = rt[1];
  return out;
}

WorldModelImpl::WorldModelImpl(const DynamicsConfig& c) : config(c) {
  const int64_t z_dim =
      c.model.policy_conditioning ? int64_t{c.policy.categories} * c.policy.classes : 0;
  dynamics = register_module("dynamics", DynamicsNet(c.model, z_dim));
  if (c.model.policy_conditioning) {
    policy = register_module("policy", PolicyEmbedding(c.model, c.policy));
  }
}

torch::Tensor WorldModelImpl::DynamicsZ(const torch::Tensor& tokens, const torch::Tensor& actions) {
  if (!policy) return {};
  torch::NoGradGuard no_grad;
  torch::Tensor logits = policy->Prior(tokens, actions);  // [B, T, C, K]
  return torch::softmax(logits, -1).flatten(2);           // [B, T, C*K]
}

DynamicsOutput WorldModelImpl::Dynamics(const torch::Tensor& masked_tokens,
                                        const torch::Tensor& actions, const torch::Tensor& z) {
  return dynamics->forward(masked_tokens, actions, z);
}

WorldModelLosses WorldModelImpl::Losses(const SegmentBatch& b) {
  WorldModelLosses l;
  const int64_t T = b.tokens.size(1), K = config.model.num_codes;
  torch::Tensor z;
  if (policy) {
    PolicyOutput po = policy->forward(b.tokens, b.actions, b.z_noise);
    l.policy = policy->Losses(po, b.actions);
    z = torch::softmax(po.prior_logits.detach(), -1).flatten(2);  // [B, T, C*K], stop-gradient
  }
  torch::Tensor input = b.tokens.masked_fill(b.mask, K);  // [B, T, N]
  DynamicsOutput out = dynamics->forward(input, b.actions, z);
  // MaskGIT: cross-entropy on the masked tokens only.
  torch::Tensor ce = F::cross_entropy(out.logits.reshape({-1, K}), b.tokens.reshape({-1}),
                                      F::CrossEntropyFuncOptions().reduction(torch::kNone));
  torch::Tensor m = b.mask.reshape({-1}).to(ce.scalar_type());
  torch::Tensor n = b.token_normalizer > 0 ? torch::scalar_tensor(b.token_normalizer, m.options())
                                           : m.sum().clamp_min(1);
  l.token_ce = (ce * m).sum() / n;
  {
    torch::NoGradGuard no_grad;
    torch::Tensor hit = (out.logits.argmax(-1).reshape({-1}) == b.tokens.reshape({-1}));
    l.token_accuracy = ((hit.to(m.scalar_type()) * m).sum() / n).item<double>();
  }
  // Position j >= 1 predicts the reward and terminal flag of step j-1.
  l.reward_mse = F::mse_loss(out.reward.slice(1, 1, T), b.rewards.slice(1, 0, T - 1));
  l.terminal_bce = F::binary_cross_entropy_with_logits(out.terminal_logit.slice(1, 1, T),
                                                       b.terminals.slice(1, 0, T - 1));
  const TrainConfig& t = config.train;
  l.dynamics = l.token_ce + t.reward_weight * l.reward_mse + t.terminal_weight * l.terminal_bce;
  l.total = l.policy ? l.dynamics + t.policy_weight * l.policy->loss : l.dynamics;
  return l;
}

}  // namespace wm::train

#include "train/world_model.h"

#include <cmath>
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

namespace {

AdaptiveNorm BlockNorm(const std::string& adaptive_norm) {  // model.adaptive_norm
  if (adaptive_norm == "identity") return AdaptiveNorm::kIdentity;
  if (adaptive_norm == "zero") return AdaptiveNorm::kZero;
  return AdaptiveNorm::kOff;
}

}  // namespace

DynamicsNetImpl::DynamicsNetImpl(const ModelConfig& m, int64_t z_dim) : config(m), z_dim(z_dim) {
  const int64_t d = m.d_model, L = m.levels;
  token_embed = register_module("token_embed", torch::nn::Embedding(L * (m.num_codes + 1), d));
  spatial_pos = register_parameter("spatial_pos", torch::randn({m.cells(), d}) * 0.02);
  if (!rope_time()) {
    temporal_pos = register_parameter("temporal_pos", torch::randn({m.context_frames, d}) * 0.02);
  }
  action_start = register_parameter("action_start", torch::randn({d}) * 0.02);
  action_in = register_module("action_in", torch::nn::Linear(m.action_dim, d));
  if (z_dim > 0) z_in = register_module("z_in", torch::nn::Linear(z_dim, d));
  transformer = register_module(
      "transformer", StTransformer(StBlockOptions{.dim = d,
                                                  .heads = m.num_heads,
                                                  .mlp_ratio = m.mlp_ratio,
                                                  .rms_norm = m.norm == "rmsnorm",
                                                  .causal_time = true,
                                                  .rope_time = rope_time(),
                                                  .adaptive_norm = BlockNorm(m.adaptive_norm)},
                                   m.num_layers));
  if (m.tied_token_head) {
    token_bias = register_parameter("token_bias", torch::zeros({L * m.num_codes}));
  } else {
    token_head = register_module("token_head", torch::nn::Linear(d, L * m.num_codes));
  }
  reward_head = register_module("reward_head", torch::nn::Linear(d, 2));
  if (m.copy_prior) copy_gate = register_module("copy_gate", torch::nn::Linear(d, L));
  InitWeights(*this);
  transformer->ZeroModulation();
  if (copy_gate) {
    // Zero-init residual (DIAMOND, iVideoGPT's action projection): the gate starts as the
    // constant log(K), which puts the previous code clearly on top of the N(0, 0.02)-initialised
    // logits (spread ~0.2) with probability about 1/2, whatever the grid or codebook.
    torch::NoGradGuard no_grad;
    copy_gate->weight.zero_();
    copy_gate->bias.fill_(std::log(static_cast<double>(m.num_codes)));
  }
}

StInput DynamicsNetImpl::Embed(const torch::Tensor& tokens, const torch::Tensor& actions,
                               const torch::Tensor& z) {
  const int64_t B = tokens.size(0), T = tokens.size(1);
  // "masked": position j carries a_{j-1} and z_{j-1} (eq. 5: x_{h+1} | x_{1:h}, a_{1:h}, z_h) and
  // a learned start vector at j = 0. "next_frame": position j carries a_j and z_j and predicts
  // frame j+1 itself (action_start is then unused).
  const bool shifted = next_frame();
  const int64_t n_cond = shifted ? T : T - 1;
  torch::Tensor past = actions.slice(1, 0, n_cond);
  // The action-blind control sees zeros: same parameters, no information in the actions.
  if (!config.action_conditioning) past = torch::zeros_like(past);
  torch::Tensor cond = action_in->forward(past);
  if (!shifted) cond = torch::cat({action_start.expand({B, 1, -1}), cond}, 1);  // [B, T, D]
  if (z_dim > 0) {
    torch::Tensor zc = z_in->forward(z.slice(1, 0, n_cond));
    cond = cond + (shifted ? zc : F::pad(zc, F::PadFuncOptions({0, 0, 1, 0})));  // [B, T, D]
  }
  // adaLN reads what the frame is told, not where it sits in the window (blocks without it
  // ignore it).
  const torch::Tensor frame_cond = cond;
  if (temporal_pos.defined()) cond = cond + temporal_pos.slice(0, 0, T);
  return {EmbedCodes(tokens) + spatial_pos + cond.unsqueeze(2), frame_cond};  // [B, T, cells, D]
}

torch::Tensor DynamicsNetImpl::EmbedCodes(const torch::Tensor& tokens) {
  const int64_t L = config.levels;
  if (L == 1) return token_embed->forward(tokens);
  const int64_t B = tokens.size(0), T = tokens.size(1);
  const torch::Tensor first_row =
      torch::arange(L, tokens.options()).mul_(config.num_codes + 1).view({L, 1});
  return token_embed->forward(tokens.reshape({B, T, L, -1}) + first_row).sum(2);
}

namespace {

// Per-cell, per-level outputs [B, T, cells, L * C] (level-major within a cell) as per-token
// outputs [B, T, L * cells, C] in the frame's level-major token order.
torch::Tensor TokenMajor(const torch::Tensor& x, int64_t L) {
  const int64_t B = x.size(0), T = x.size(1), cells = x.size(2);
  return x.reshape({B, T, cells, L, -1}).permute({0, 1, 3, 2, 4}).reshape({B, T, L * cells, -1});
}

}  // namespace

torch::Tensor DynamicsNetImpl::TokenLogits(const torch::Tensor& h, const torch::Tensor& prev) {
  const int64_t K = config.num_codes, L = config.levels;
  // Tied: each level's code rows of the input embedding (not its mask row) score its codes.
  torch::Tensor logits =
      token_head
          ? token_head->forward(h)
          : ApplyLinear(
                h, token_embed->weight.view({L, K + 1, -1}).slice(1, 0, K).reshape({L * K, -1}),
                token_bias);
  logits = TokenMajor(logits, L);  // [B, T, N, K]
  if (!copy_gate) return logits;
  torch::Tensor gate = TokenMajor(copy_gate->forward(h), L);  // [B, T, N, 1]
  gate = gate * (prev < K).unsqueeze(-1).to(gate.scalar_type());
  return logits.scatter_add(-1, prev.clamp_max(K - 1).unsqueeze(-1), gate.to(logits.scalar_type()));
}

void DynamicsNetImpl::RewardHead(const torch::Tensor& h, DynamicsOutput& out) {
  auto rt = reward_head->forward(h.mean(2)).unbind(-1);  // 2x [B, T]
  out.reward = rt[0];
  out.terminal_logit = rt[1];
}

DynamicsOutput DynamicsNetImpl::forward(const torch::Tensor& tokens, const torch::Tensor& actions,
                                        const torch::Tensor& z, const TimeAxis& time) {
  const int64_t T = tokens.size(1), K = config.num_codes;
  torch::Tensor h = transformer->Forward(Embed(tokens, actions, z), time);  // [B, T, N, D]
  // The code each position's predicted frame had one frame earlier: the input frame itself when
  // predicting the next one, else the input one position back (none at j = 0; a masked one gets
  // no bonus).
  torch::Tensor prev =
      next_frame()
          ? tokens
          : torch::cat({torch::full_like(tokens.slice(1, 0, 1), K), tokens.slice(1, 0, T - 1)},
                       1);  // [B, T, N]
  DynamicsOutput out;
  out.logits = TokenLogits(h, prev);
  RewardHead(h, out);
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
  torch::Tensor logits = policy->Prior(PolicyTokens(tokens), actions);  // [B, T, C, K]
  return torch::softmax(logits, -1).flatten(2);                         // [B, T, C*K]
}

torch::Tensor WorldModelImpl::PolicyTokens(const torch::Tensor& tokens) const {
  return tokens.slice(2, 0, config.model.cells());
}

DynamicsOutput WorldModelImpl::Dynamics(const torch::Tensor& tokens, const torch::Tensor& actions,
                                        const torch::Tensor& z) {
  return dynamics->forward(tokens, actions, z);
}

torch::Tensor WorldModelImpl::NextFrameLogits(const torch::Tensor& context,
                                              const torch::Tensor& actions, const torch::Tensor& z,
                                              const torch::Tensor& partial) {
  const int64_t B = context.size(0), Tc = context.size(1), N = context.size(2);
  if (dynamics->next_frame())
    return dynamics->forward(context, actions, z).logits.select(1, Tc - 1);
  auto pad_frame = [](const torch::Tensor& x) {  // [B, Tc, ...] -> [B, Tc + 1, ...]
    return torch::cat({x, torch::zeros_like(x.slice(1, 0, 1))}, 1);
  };
  torch::Tensor frame = partial.defined()
                            ? partial.view({B, 1, N})
                            : torch::full({B, 1, N}, config.model.num_codes, context.options());
  return dynamics
      ->forward(torch::cat({context, frame}, 1), pad_frame(actions), z.defined() ? pad_frame(z) : z)
      .logits.select(1, Tc);
}

WorldModelLosses WorldModelImpl::Losses(const SegmentBatch& b) {
  WorldModelLosses l;
  const int64_t T = b.tokens.size(1), K = config.model.num_codes;
  // A narrower dataset's padding is zeroed whatever it holds, so it reaches no action layer
  // (W * 0 adds nothing), and stays out of the policy NLL (Octo's action padding mask).
  const torch::Tensor actions = b.action_mask.defined() ? b.actions * b.action_mask : b.actions;
  torch::Tensor z;
  if (policy) {
    PolicyOutput po = policy->forward(PolicyTokens(b.tokens), actions, b.z_noise);
    l.policy = policy->Losses(po, actions, b.action_mask);
    z = torch::softmax(po.prior_logits.detach(), -1).flatten(2);  // [B, T, C*K], stop-gradient
  }
  const bool shifted = dynamics->next_frame();
  // MaskGIT: the masked tokens are the input's holes and the targets. Next-frame: the input is
  // clean and position j's logits are scored against frame j+1.
  torch::Tensor input = shifted ? b.tokens : b.tokens.masked_fill(b.mask, K);  // [B, T, N]
  DynamicsOutput out = dynamics->forward(input, actions, z);
  torch::Tensor logits = shifted ? out.logits.slice(1, 0, T - 1) : out.logits;
  torch::Tensor target = shifted ? b.tokens.slice(1, 1, T) : b.tokens;
  torch::Tensor is_target = shifted ? b.mask.slice(1, 1, T) : b.mask;
  torch::Tensor ce = F::cross_entropy(logits.reshape({-1, K}), target.reshape({-1}),
                                      F::CrossEntropyFuncOptions().reduction(torch::kNone));
  torch::Tensor m = is_target.reshape({-1}).to(ce.scalar_type());
  torch::Tensor n = b.token_normalizer > 0 ? torch::scalar_tensor(b.token_normalizer, m.options())
                                           : m.sum().clamp_min(1);
  l.token_ce = (ce * m).sum() / n;
  {
    torch::NoGradGuard no_grad;
    torch::Tensor hit = (logits.argmax(-1).reshape({-1}) == target.reshape({-1}));
    l.token_accuracy = ((hit.to(m.scalar_type()) * m).sum() / n).item<double>();
  }
  // Position j predicts the reward and terminal flag of step j, the ones RLDS logs with frame j
  // (tabletop's reward 1 comes with the frame showing the block in the goal, on an episode's last
  // step: a target only a position that sees that frame can learn).
  l.reward_mse = F::mse_loss(out.reward, b.rewards);
  l.terminal_bce = F::binary_cross_entropy_with_logits(out.terminal_logit, b.terminals);
  const TrainConfig& t = config.train;
  l.dynamics = l.token_ce + t.reward_weight * l.reward_mse + t.terminal_weight * l.terminal_bce;
  l.total = l.policy ? l.dynamics + t.policy_weight * l.policy->loss : l.dynamics;
  return l;
}

}  // namespace wm::train

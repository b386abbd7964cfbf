#include "train/policy_embedding.h"

#include <cmath>
#include <numbers>

namespace wm::train {

torch::Tensor StraightThroughSample(const torch::Tensor& logits, const torch::Tensor& u) {
  const int64_t K = logits.size(-1);
  torch::Tensor gumbel = -torch::log(-torch::log(u));
  torch::Tensor index = (logits.detach() + gumbel).argmax(-1);             // [...]
  torch::Tensor hard = torch::one_hot(index, K).to(logits.scalar_type());  // [..., K]
  torch::Tensor probs = torch::softmax(logits, -1);
  return hard + probs - probs.detach();  // straight-through (Bengio et al. 2013)
}

torch::Tensor CategoricalKl(const torch::Tensor& q_logits, const torch::Tensor& p_logits) {
  torch::Tensor log_q = torch::log_softmax(q_logits, -1), log_p = torch::log_softmax(p_logits, -1);
  return (log_q.exp() * (log_q - log_p)).sum({-2, -1});  // [..., C, K] -> [...]
}

torch::Tensor GaussianNll(const torch::Tensor& a, const torch::Tensor& mean,
                          const torch::Tensor& log_std, const torch::Tensor& mask) {
  const double half_log_2pi = 0.5 * std::log(2.0 * std::numbers::pi);
  torch::Tensor z = (a - mean) * torch::exp(-log_std);
  torch::Tensor per_dim = 0.5 * z.pow(2) + log_std + half_log_2pi;  // [..., A]
  return (mask.defined() ? per_dim * mask : per_dim).sum(-1);       // [...]
}

PolicyEmbeddingImpl::PolicyEmbeddingImpl(const ModelConfig& m, const PolicyConfig& p) : config(p) {
  const int64_t d = p.d_model, zdim = int64_t{p.categories} * p.classes;
  const int64_t N = m.cells(), A = m.action_dim;  // it reads a frame's first level
  token_embed = register_module("token_embed", torch::nn::Embedding(m.num_codes, d));
  spatial_pos = register_parameter("spatial_pos", torch::randn({N, d}) * 0.02);
  temporal_pos = register_parameter("temporal_pos", torch::randn({m.context_frames, d}) * 0.02);
  posterior_action = register_module("posterior_action", torch::nn::Linear(A, d));
  prior_action = register_module("prior_action", torch::nn::Linear(A, d));
  decoder_prev_action = register_module("decoder_prev_action", torch::nn::Linear(A, d));
  decoder_z = register_module("decoder_z", torch::nn::Linear(zdim, d));
  decoder_start = register_parameter("decoder_start", torch::randn({d}) * 0.02);
  StBlockOptions o{.dim = d,
                   .heads = p.num_heads,
                   .mlp_ratio = m.mlp_ratio,
                   .rms_norm = m.norm == "rmsnorm",
                   .causal_time = true};
  StBlockOptions bidirectional = o;
  bidirectional.causal_time = false;
  posterior = register_module("posterior", StTransformer(bidirectional, p.posterior_layers));
  prior = register_module("prior", StTransformer(o, p.prior_layers));
  decoder = register_module("decoder", StTransformer(o, p.decoder_layers));
  posterior_head = register_module("posterior_head", torch::nn::Linear(d, zdim));
  prior_head = register_module("prior_head", torch::nn::Linear(d, zdim));
  decoder_head = register_module("decoder_head", torch::nn::Linear(d, 2 * A));
  InitWeights(*this);
}

torch::Tensor PolicyEmbeddingImpl::Embed(const torch::Tensor& tokens, const torch::Tensor& extra) {
  const int64_t T = tokens.size(1);
  return token_embed->forward(tokens) + spatial_pos +         // [B, T, N, Dp]
         (temporal_pos.slice(0, 0, T) + extra).unsqueeze(2);  // [B, T, 1, Dp]
}

torch::Tensor PolicyEmbeddingImpl::Prior(const torch::Tensor& tokens,
                                         const torch::Tensor& actions) {
  const int64_t B = tokens.size(0), T = tokens.size(1);
  // Position h sees o_{<=h} and a_{<=h}: tau_h of eq. 4.
  torch::Tensor h = prior->forward(Embed(tokens, prior_action->forward(actions)));  // [B,T,N,Dp]
  return prior_head->forward(h.mean(2)).view({B, T, config.categories, config.classes});
}

PolicyOutput PolicyEmbeddingImpl::forward(const torch::Tensor& tokens, const torch::Tensor& actions,
                                          const torch::Tensor& noise) {
  const int64_t B = tokens.size(0), T = tokens.size(1), C = config.categories;
  const int64_t K = config.classes;
  PolicyOutput out;
  torch::Tensor hq = posterior->forward(Embed(tokens, posterior_action->forward(actions)));
  out.posterior_logits = posterior_head->forward(hq.mean({1, 2})).view({B, C, K});  // [B, C, K]
  out.prior_logits = Prior(tokens, actions);                                        // [B,T,C,K]
  out.z = StraightThroughSample(out.posterior_logits, noise).view({B, C * K});      // [B, C*K]
  // Decoder input at h: o_h, a_{h-1} (a learned start vector at h = 0) and z.
  torch::Tensor prev = torch::cat(
      {decoder_start.expand({B, 1, -1}), decoder_prev_action->forward(actions.slice(1, 0, T - 1))},
      1);                                                               // [B, T, Dp]
  torch::Tensor extra = prev + decoder_z->forward(out.z).unsqueeze(1);  // [B, T, Dp]
  torch::Tensor hd = decoder->forward(Embed(tokens, extra)).mean(2);    // [B, T, Dp]
  auto mean_logstd = decoder_head->forward(hd).chunk(2, -1);            // 2x [B,T,D]
  out.action_mean = mean_logstd[0];
  out.action_log_std = mean_logstd[1].clamp(config.log_std_min, config.log_std_max);
  return out;
}

PolicyLosses PolicyEmbeddingImpl::Losses(const PolicyOutput& out, const torch::Tensor& actions,
                                         const torch::Tensor& action_mask) const {
  PolicyLosses l;
  l.nll = GaussianNll(actions, out.action_mean, out.action_log_std, action_mask).sum(1).mean();
  const int64_t T = out.prior_logits.size(1);
  torch::Tensor q = out.posterior_logits.unsqueeze(1).expand({-1, T, -1, -1});  // [B, T, C, K]
  l.kl = CategoricalKl(q, out.prior_logits).sum(1).mean();  // sum_h KL(q || p_h), eq. 4
  l.loss = l.nll + config.kl_beta * l.kl;
  return l;
}

}  // namespace wm::train

#include "train/batch.h"

#include <ATen/CPUGeneratorImpl.h>

#include <cmath>
#include <numbers>

#include "core/error.h"

namespace wm::train {

StepNoise DrawStepNoise(const DynamicsConfig& c, uint64_t seed, int64_t step, int64_t batch) {
  const int64_t T = c.model.context_frames, N = int64_t{c.model.grid_h} * c.model.grid_w;
  at::Generator gen = at::detail::createCPUGenerator(MixSeed(seed ^ 0x6D61736Bull, step));
  StepNoise n;
  n.u_ratio = torch::rand({batch, T}, gen);
  n.u_order = torch::rand({batch, T, N}, gen);
  n.z_noise = torch::rand({batch, c.policy.categories, c.policy.classes}, gen);
  n.u_frame = torch::rand({batch, T}, gen);
  return n;
}

SegmentBatch MakeSegmentBatch(const DynamicsConfig& c, const SegmentData& d, const StepNoise& noise,
                              int64_t first, int world_size, const torch::Device& device) {
  const int64_t B = d.batch, T = c.model.context_frames;
  const int64_t N = int64_t{c.model.grid_h} * c.model.grid_w;
  auto host = [&](const auto& v, std::vector<int64_t> shape, torch::ScalarType type) {
    return torch::from_blob(const_cast<void*>(static_cast<const void*>(v.data())), shape,
                            torch::TensorOptions().dtype(type))
        .to(device, /*non_blocking=*/false, /*copy=*/true);
  };
  SegmentBatch b;
  b.tokens = host(d.tokens, {B, T, N}, torch::kInt64);
  b.actions = host(d.actions, {B, T, 7}, torch::kFloat);
  b.rewards = host(d.rewards, {B, T}, torch::kFloat);
  b.terminals = host(d.terminals, {B, T}, torch::kFloat);
  torch::Tensor global_mask = TrainingMask(noise.u_ratio, noise.u_order, noise.u_frame,
                                           c.model.mask_frame_prob);  // [Bg, T, N]
  b.mask = global_mask.slice(0, first, first + B).to(device);         // [B, T, N]
  b.z_noise = noise.z_noise.slice(0, first, first + B).to(device);    // [B, C, K]
  b.token_normalizer =
      std::max<double>(1.0, global_mask.sum().item<double>()) / static_cast<double>(world_size);
  return b;
}

torch::Tensor DecodeNextFrame(WorldModel& model, const torch::Tensor& tokens,
                              const torch::Tensor& actions, const torch::Tensor& z, int steps,
                              double temperature, const std::vector<uint64_t>& row_seeds) {
  torch::NoGradGuard no_grad;
  const int64_t B = tokens.size(0), Tc = tokens.size(1), N = tokens.size(2);
  const int64_t K = model->config.model.num_codes;
  Check(static_cast<int64_t>(row_seeds.size()) == B,
        "DecodeNextFrame: " + std::to_string(row_seeds.size()) + " row seeds for " +
            std::to_string(B) + " rows");
  std::vector<at::Generator> gens;
  for (uint64_t seed : row_seeds) gens.push_back(at::detail::createCPUGenerator(seed));
  auto pad_frame = [](const torch::Tensor& x) {  // [B, Tc, ...] -> [B, Tc + 1, ...]
    return torch::cat({x, torch::zeros_like(x.slice(1, 0, 1))}, 1);
  };
  torch::Tensor seq = torch::cat({tokens, torch::full({B, 1, N}, K, tokens.options())}, 1);
  torch::Tensor act = pad_frame(actions), zz = z.defined() ? pad_frame(z) : z;
  torch::Tensor masked = torch::ones({B, N}, torch::kBool);  // CPU bookkeeping
  for (int s = 0; s < steps; ++s) {
    torch::Tensor logits = model->Dynamics(seq, act, zz).logits.select(1, Tc);  // [B, N, K]
    torch::Tensor logp = torch::log_softmax(logits.to(torch::kCPU, torch::kFloat), -1);
    torch::Tensor choice;
    if (temperature > 0) {
      torch::Tensor probs = torch::softmax(logp / temperature, -1);  // [B, N, K]
      choice = torch::empty({B, N}, torch::kInt64);
      for (int64_t b = 0; b < B; ++b) {
        choice[b].copy_(torch::multinomial(probs[b], 1, /*replacement=*/true, gens[b]).view({N}));
      }
    } else {
      choice = logp.argmax(-1);  // [B, N]
    }
    torch::Tensor confidence = logp.gather(-1, choice.unsqueeze(-1)).squeeze(-1);  // [B, N]
    confidence.masked_fill_(masked.logical_not(), std::numeric_limits<float>::infinity());
    const auto keep_masked =
        static_cast<int64_t>(std::floor(N * std::cos(std::numbers::pi / 2 * (s + 1) / steps)));
    // Tokens fixed after this round: every position except the keep_masked least confident.
    torch::Tensor order = torch::argsort(confidence, -1, false);  // [B, N]
    torch::Tensor newly = torch::zeros({B, N}, torch::kBool);
    newly.scatter_(1, order.slice(1, keep_masked, N), true);
    newly.logical_and_(masked);
    torch::Tensor frame = seq.select(1, Tc).to(torch::kCPU);  // [B, N]
    frame = torch::where(newly, choice, frame);
    seq.select(1, Tc).copy_(frame.to(seq.device()));
    masked.logical_and_(newly.logical_not());
  }
  return seq.select(1, Tc).to(torch::kCPU).clone();  // [B, N]
}

}  // namespace wm::train

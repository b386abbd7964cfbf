#include "train/batch.h"

#include <ATen/CPUGeneratorImpl.h>

#include <cmath>
#include <numbers>

#include "core/error.h"

namespace wm::train {

StepNoise DrawStepNoise(const DynamicsConfig& c, uint64_t seed, int64_t step, int64_t batch) {
  const int64_t T = c.model.context_frames, N = c.model.tokens_per_frame();
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
  const int64_t B = d.batch, T = c.model.context_frames, N = c.model.tokens_per_frame();
  auto host = [&](const auto& v, std::vector<int64_t> shape, torch::ScalarType type) {
    return torch::from_blob(const_cast<void*>(static_cast<const void*>(v.data())), shape,
                            torch::TensorOptions().dtype(type))
        .to(device, /*non_blocking=*/false, /*copy=*/true);
  };
  SegmentBatch b;
  b.tokens = host(d.tokens, {B, T, N}, torch::kInt64);
  const int64_t D = c.model.action_dim;
  Check(static_cast<int64_t>(d.actions.size()) == B * T * D,
        "segments have " + std::to_string(d.actions.size() / std::max<int64_t>(B * T, 1)) +
            " action values per step, the model takes " + std::to_string(D));
  b.actions = host(d.actions, {B, T, D}, torch::kFloat);
  if (!d.action_mask.empty()) b.action_mask = host(d.action_mask, {B, 1, D}, torch::kFloat);
  b.rewards = host(d.rewards, {B, T}, torch::kFloat);
  b.terminals = host(d.terminals, {B, T}, torch::kFloat);
  torch::Tensor global_mask;                // [Bg, T, N]
  if (c.model.objective == "next_frame") {  // every token of frames 1..T-1 is a target
    global_mask = torch::ones_like(noise.u_order, torch::kBool);
    global_mask.select(1, 0).fill_(false);
  } else {
    global_mask =
        TrainingMask(noise.u_ratio, noise.u_order, noise.u_frame, c.model.mask_frame_prob);
  }
  b.mask = global_mask.slice(0, first, first + B).to(device);       // [B, T, N]
  b.z_noise = noise.z_noise.slice(0, first, first + B).to(device);  // [B, C, K]
  b.token_normalizer =
      std::max<double>(1.0, global_mask.sum().item<double>()) / static_cast<double>(world_size);
  return b;
}

namespace {

// One code per token from log-probabilities [B, N, K]: argmax at temperature 0, else a sample
// of softmax(logp / temperature) from row b's own generator.
torch::Tensor ChooseCodes(const torch::Tensor& logp, double temperature,
                          std::vector<at::Generator>& gens) {
  const int64_t B = logp.size(0), N = logp.size(1);
  if (temperature <= 0) return logp.argmax(-1);                  // [B, N]
  torch::Tensor probs = torch::softmax(logp / temperature, -1);  // [B, N, K]
  torch::Tensor choice = torch::empty({B, N}, torch::kInt64);
  for (int64_t b = 0; b < B; ++b) {
    choice[b].copy_(torch::multinomial(probs[b], 1, /*replacement=*/true, gens[b]).view({N}));
  }
  return choice;
}

}  // namespace

torch::Tensor Entropy(const torch::Tensor& log_probs) {
  const torch::Tensor p = log_probs.exp();
  return -torch::xlogy(p, p).sum(-1);  // xlogy: 0 log 0 = 0 where a code has probability 0
}

torch::Tensor SampleFrame(const FrameLogProbs& log_probs, int64_t N, int64_t K, bool one_pass,
                          int steps, double temperature, const std::vector<uint64_t>& row_seeds,
                          torch::Tensor* token_entropy) {
  const auto B = static_cast<int64_t>(row_seeds.size());
  std::vector<at::Generator> gens;
  for (uint64_t seed : row_seeds) gens.push_back(at::detail::createCPUGenerator(seed));
  // Next-frame models predict every token at once from the clean context: one pass.
  if (one_pass) {
    torch::Tensor logp = log_probs({});
    if (token_entropy) *token_entropy = Entropy(logp);
    return ChooseCodes(logp, temperature, gens).contiguous();
  }
  torch::Tensor frame = torch::full({B, N}, K, torch::kInt64);  // CPU; K = still masked
  torch::Tensor masked = torch::ones({B, N}, torch::kBool);     // CPU bookkeeping
  if (token_entropy) *token_entropy = torch::zeros({B, N}, torch::kFloat);
  for (int s = 0; s < steps; ++s) {
    torch::Tensor logp = log_probs(frame);
    torch::Tensor choice = ChooseCodes(logp, temperature, gens);
    torch::Tensor confidence = logp.gather(-1, choice.unsqueeze(-1)).squeeze(-1);  // [B, N]
    confidence.masked_fill_(masked.logical_not(), std::numeric_limits<float>::infinity());
    const auto keep_masked =
        static_cast<int64_t>(std::floor(N * std::cos(std::numbers::pi / 2 * (s + 1) / steps)));
    // Tokens fixed after this round: every position except the keep_masked least confident.
    torch::Tensor order = torch::argsort(confidence, -1, false);  // [B, N]
    torch::Tensor newly = torch::zeros({B, N}, torch::kBool);
    newly.scatter_(1, order.slice(1, keep_masked, N), true);
    newly.logical_and_(masked);
    frame = torch::where(newly, choice, frame);
    if (token_entropy) *token_entropy = torch::where(newly, Entropy(logp), *token_entropy);
    masked.logical_and_(newly.logical_not());
  }
  return frame;  // [B, N]
}

torch::Tensor DecodeNextFrame(WorldModel& model, const torch::Tensor& tokens,
                              const torch::Tensor& actions, const torch::Tensor& z, int steps,
                              double temperature, const std::vector<uint64_t>& row_seeds,
                              torch::Tensor* token_entropy) {
  torch::NoGradGuard no_grad;
  const int64_t B = tokens.size(0), N = tokens.size(2);
  Check(static_cast<int64_t>(row_seeds.size()) == B,
        "DecodeNextFrame: " + std::to_string(row_seeds.size()) + " row seeds for " +
            std::to_string(B) + " rows");
  auto log_probs = [&](const torch::Tensor& partial) {  // [B, N, K] on the CPU
    torch::Tensor logits = model->NextFrameLogits(
        tokens, actions, z, partial.defined() ? partial.to(tokens.device()) : partial);
    return torch::log_softmax(logits.to(torch::kCPU, torch::kFloat), -1);
  };
  return SampleFrame(log_probs, N, model->config.model.num_codes,
                     model->config.model.objective == "next_frame", steps, temperature, row_seeds,
                     token_entropy);
}

}  // namespace wm::train

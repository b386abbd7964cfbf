#pragma once
// Host segments -> device tensors, with the step's randomness drawn counter-based for the
// *global* batch (every rank draws the same noise and keeps its rows), so a data-parallel run
// trains on exactly the masks and posterior samples of a single-process run. Also MaskGIT
// inference. Internal header (includes torch).
#include <torch/torch.h>

#include <cstdint>
#include <functional>
#include <vector>

#include "train/segment_sampler.h"
#include "train/world_model.h"

namespace wm::train {

// Uniform noise of one global step: mask ratios [B, T], mask orders [B, T, N], posterior-sample
// noise [B, C, K], target-frame draws [B, T]; drawn in that order from a torch CPU generator
// seeded MixSeed(seed, step).
struct StepNoise {
  torch::Tensor u_ratio, u_order, z_noise, u_frame;
};
StepNoise DrawStepNoise(const DynamicsConfig& config, uint64_t seed, int64_t step, int64_t batch);

// Rows [first, first + data.batch) of the global batch as a SegmentBatch on `device`. The token
// cross-entropy is normalised by the global batch's masked-token count / world_size, so the mean
// over ranks of the local losses (and gradients) equals the single-process ones.
SegmentBatch MakeSegmentBatch(const DynamicsConfig& config, const SegmentData& data,
                              const StepNoise& noise, int64_t first, int world_size,
                              const torch::Device& device);

// The sampling loop of DecodeNextFrame over `log_probs(partial)`: CPU log-probabilities
// [B, N, K] of the new frame's tokens given `partial` [B, N] (CPU, mask token K where still
// unknown; undefined for `one_pass`). B = row_seeds.size(). Returns [B, N] int64 on the CPU.
// `token_entropy`, when given, receives [B, N] float: the entropy (nats) of each token's
// distribution, untempered, in the round that fixed it (the one pass of a next-frame model);
// the frame sampled does not depend on it.
using FrameLogProbs = std::function<torch::Tensor(const torch::Tensor& partial)>;
torch::Tensor SampleFrame(const FrameLogProbs& log_probs, int64_t N, int64_t K, bool one_pass,
                          int steps, double temperature, const std::vector<uint64_t>& row_seeds,
                          torch::Tensor* token_entropy = nullptr);

// Entropy (nats) over the last axis of log-probabilities: [..., K] -> [...].
torch::Tensor Entropy(const torch::Tensor& log_probs);

// Decoding of the frame after `tokens` [B, Tc, N] (Tc < context_frames) with actions
// [B, Tc, D] (normalised, padding zeroed; the last one leads to the new frame) and z [B, Tc, z_dim]
// (undefined without policy conditioning): `steps` rounds, each sampling every masked token
// (temperature 0 = argmax) and keeping the most confident so that cos(pi/2 * (s+1)/steps) of the
// frame stays masked ("masked" objective; a "next_frame" model samples every token in one pass and
// ignores `steps`). Row b samples with its own CPU generator seeded `row_seeds[b]`, so a row's
// frame does not depend on the other rows of the batch (sharded evaluation reproduces a whole run).
// Returns [B, N] int64; `token_entropy` as for SampleFrame.
torch::Tensor DecodeNextFrame(WorldModel& model, const torch::Tensor& tokens,
                              const torch::Tensor& actions, const torch::Tensor& z, int steps,
                              double temperature, const std::vector<uint64_t>& row_seeds,
                              torch::Tensor* token_entropy = nullptr);

}  // namespace wm::train

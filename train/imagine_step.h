#pragma once
// One imagination step with the context window encoded once (issue 21 item 7). The reference
// path (DecodeNextFrame, then DynamicsNet::forward over the window extended by the new frame for
// its reward) runs the transformer over the whole window once per MaskGIT round and once more
// for the reward. The temporal attention is causal, so the window's frames do not depend on the
// frame after them: CachedWindow runs the window once, keeps each block's temporal keys/values
// (TemporalCache), and each round and the reward pass compute only the new frame's position.
// Results equal the reference up to float rounding (other GEMM shapes); tested in
// tests/train/imagine_step_test.cc. The cache lives for one step: positions are absolute within
// the window, so when the window slides by a frame every frame's keys change. Internal header
// (includes torch).
#include <torch/torch.h>

#include <cstdint>
#include <vector>

#include "train/world_model.h"

namespace wm::train {

class CachedWindow {
 public:
  // The window: tokens [B, Tc, N] (Tc < context_frames), actions [B, Tc, D] (normalised; the
  // last leads to the new frame), z [B, Tc, z_dim] (undefined without policy conditioning), as
  // DecodeNextFrame takes them.
  CachedWindow(WorldModel& model, const torch::Tensor& tokens, const torch::Tensor& actions,
               const torch::Tensor& z);

  // CPU log-probabilities [B, N, K] of the new frame's tokens given `partial` [B, N] (mask token
  // K where still unknown; ignored by "next_frame", whose last window position predicts them).
  torch::Tensor LogProbs(const torch::Tensor& partial);

  // The next frame [B, N] (CPU int64), sampled exactly as DecodeNextFrame samples it from its
  // log-probabilities (row b with its own generator seeded row_seeds[b]).
  torch::Tensor DecodeNext(int steps, double temperature, const std::vector<uint64_t>& row_seeds);

  // The reward and terminal logit [B] of the step to the new frame: DynamicsNet::forward's at
  // position Tc of the window extended by it. `tokens`, `actions`, `z` hold the extended window
  // ([B, Tc + 1, ...]; z as the model gets it for that window, undefined without conditioning).
  DynamicsOutput StepReward(const torch::Tensor& tokens, const torch::Tensor& actions,
                            const torch::Tensor& z);

 private:
  // The transformer's output [B, 1, N, D] at position Tc for the embedded window extended by
  // one frame, x [B, Tc + 1, N, D].
  torch::Tensor NewFrameOutput(const StInput& x);

  WorldModel& model_;
  torch::Tensor tokens_, actions_, z_;
  TemporalCache cache_;
  torch::Tensor last_output_;  // [B, 1, N, D]: the window's last frame (next_frame's logits)
};

}  // namespace wm::train

#pragma once
// Closed-loop imagination that keeps every frame's temporal keys/values as the window slides
// (issue 21 item 7), for next-frame models with rotary time (model.temporal_positions "rope").
//
// The window path (CachedWindow) re-encodes the whole window every step: with learned positions
// a frame's keys depend on its slot, which changes when the window slides. With rotary time they
// depend on the frame's own index, so each frame is encoded once, when it is the newest, and its
// keys/values are kept: per imagined frame one pass for the frame with its action (its logits give
// the next frame) and one for the reward of the step to the new frame, instead of the window's
// context_frames passes.
//
// The attention spans are the window path's: the frame being decoded sees the context_frames - 2
// frames before it, the reward pass context_frames - 1. So for the first context_frames - 1 steps
// (before the window slides) the two paths imagine the same, up to float rounding. After that they
// differ by design: a kept frame's keys were computed from the frames before *it* (a frame sees
// context_frames - 2 back, through the layers further: Mistral's rolling cache), where the window
// path recomputes them from the current window only. Its reference is a band-masked forward over
// the whole history (TimeAxis::span); tests/train/rolling_imagination_test.cc checks both.
// Internal header (includes torch).
#include <torch/torch.h>

#include <cstdint>
#include <vector>

#include "train/world_model.h"

namespace wm::train {

class RollingWindow {
 public:
  // `first` [B, N]: each episode's real first frame (int64, on the model's device).
  // `unknown_action` [D]: what the reward pass gives the new frame for the action not yet taken,
  // as the window path does (DynamicsModel: a raw zero action, normalised); undefined = zeros.
  RollingWindow(WorldModel& model, const torch::Tensor& first,
                const torch::Tensor& unknown_action = {});

  // One imagined step of the episodes `rows` ([R] int64, ascending; an episode left out once has
  // ended and may not come back), `actions` [R, D] (normalised: the action at each one's newest
  // frame), sampled as DecodeNextFrame samples (row r with its generator seeded row_seeds[r]).
  // Returns the new frames [R, N] (CPU int64); `reward` gets the step's reward and terminal
  // logit [R] each; `log_probs`, when given, the distribution sampled ([R, N, K], CPU).
  torch::Tensor Step(const torch::Tensor& rows, const torch::Tensor& actions, double temperature,
                     const std::vector<uint64_t>& row_seeds, DynamicsOutput& reward,
                     torch::Tensor* log_probs = nullptr);

  int64_t newest_index() const { return newest_; }  // the newest frame's index in the episode

 private:
  // The kept keys/values of `rows`, the newest `keep` frames of them, as ForwardAppended takes.
  TemporalCache PastOf(const torch::Tensor& rows, int64_t keep) const;
  // Appends the frame encoded by the last pass (its keys/values `added`, rows `rows`).
  void Keep(const torch::Tensor& rows, const TemporalCache& added);
  // The policy prior's z at the last of `tokens`/`actions` ([R, T, ...]), [R, 1, Z] (undefined
  // without policy conditioning).
  torch::Tensor LastZ(const torch::Tensor& tokens, const torch::Tensor& actions);
  // The transformer's output [R, 1, N, D] for frame `index` (tokens [R, 1, N], action [R, 1, D],
  // z [R, 1, Z]) after `past`; `added`, when not null, gets its keys/values.
  torch::Tensor Encode(const torch::Tensor& frame, const torch::Tensor& action,
                       const torch::Tensor& z, const TemporalCache& past, int64_t index,
                       TemporalCache* added);

  WorldModel& model_;
  int64_t context_;                           // model.context_frames
  int64_t newest_ = 0;                        // index of the newest frame
  torch::Tensor tokens_;                      // [B, W, N]: the newest W <= context_ frames
  torch::Tensor actions_;                     // [B, W - 1, D]: their actions but the newest's
  torch::Tensor unknown_action_;              // [1, 1, D]
  std::vector<torch::Tensor> keys_, values_;  // per block [B, N, H, S, hd], S <= context_ - 1
  std::vector<bool> ended_;                   // per episode: left out of a step
};

}  // namespace wm::train

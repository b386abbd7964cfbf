#pragma once
// The dynamics model of WHALE Sec. 3.3: an ST-transformer over token frames that predicts the
// tokens of frame h+1 from frames <= h, actions a_{<=h} and the policy embedding z_h of the prior
// (eq. 5), trained MaskGIT-style or teacher-forced (model.objective), plus a reward/terminal head
// (iVideoGPT Sec. 3.3). With "masked" position j of
// the sequence holds frame j (partly masked in training), the action a_{j-1} and z_{j-1}, so it
// predicts frame j's masked tokens and the reward/terminal flag of the step j-1 -> j. With
// model.objective "next_frame" position j holds clean frame j, a_j and z_j and its token logits
// predict frame j+1 (the reward/terminal flag stay those of step j-1 -> j).
// Internal header (includes torch).
#include <torch/torch.h>

#include <optional>

#include "train/config.h"
#include "train/policy_embedding.h"
#include "train/st_transformer.h"

namespace wm::train {

// One training segment batch; every tensor on the model's device.
// N below is the tokens per frame, ModelConfig::tokens_per_frame(): levels x cells, level-major.
struct SegmentBatch {
  torch::Tensor tokens;   // [B, T, N] int64 codes (clean)
  torch::Tensor actions;  // [B, T, D] float, normalised with the dataset's statistics
  // [B, 1, D] float: 1 = a real action value, 0 = padding of a dataset narrower than the model's
  // D (a mixture of widths); undefined when every row's dataset has the model's width.
  torch::Tensor action_mask;
  torch::Tensor rewards;    // [B, T] float: r_t of (o_t, a_t)
  torch::Tensor terminals;  // [B, T] float 0/1: is_terminal of step t
  // [B, T, N] bool: the target tokens, frame 0 never. "masked": replaced by the mask token;
  // "next_frame": every token of frames 1..T-1, the input stays clean.
  torch::Tensor mask;
  torch::Tensor z_noise;        // [B, C, K] uniform (0, 1) for the posterior sample
  double token_normalizer = 0;  // divides the summed masked-token CE; 0 = this batch's count
};

struct DynamicsOutput {
  torch::Tensor logits;          // [B, T, N, num_codes]: of frame j ("masked") or j+1
  torch::Tensor reward;          // [B, T]: position j predicts r_{j-1} (j = 0 is unused)
  torch::Tensor terminal_logit;  // [B, T]: position j predicts is_terminal_{j-1}
};

struct WorldModelLosses {
  torch::Tensor token_ce, reward_mse, terminal_bce, dynamics;  // dynamics = weighted sum
  std::optional<PolicyLosses> policy;
  torch::Tensor total;
  double token_accuracy = 0;  // on masked tokens
};

struct DynamicsNetImpl : torch::nn::Module {
  explicit DynamicsNetImpl(const ModelConfig& config, int64_t z_dim);
  // tokens [B, T, N] (value num_codes = mask), actions [B, T, D], z [B, T, z_dim] (z_h at h) or
  // undefined when policy conditioning is off. `time`: where the frames sit (rotary time) and
  // how far back each sees (a band, for histories longer than a training segment).
  DynamicsOutput forward(const torch::Tensor& tokens, const torch::Tensor& actions,
                         const torch::Tensor& z, const TimeAxis& time = {});
  // forward() in parts, for decoding with a temporal cache (train/imagine_step.h):
  // the transformer's input [B, T, N, D] (token, grid and window-position embeddings and the
  // action/z conditioning of each position) and that conditioning per frame [B, T, D], without
  // the window position, for blocks with adaptive norm,
  StInput Embed(const torch::Tensor& tokens, const torch::Tensor& actions, const torch::Tensor& z);
  // the token logits [B, T, N, K] of the transformer's output h [B, T, N, D], given `prev`
  // [B, T, N], the code each position's predicted frame had one frame earlier (K: none; the copy
  // prior's bonus goes to it),
  torch::Tensor TokenLogits(const torch::Tensor& h, const torch::Tensor& prev);
  // and the reward and terminal logit [B, T] of each position.
  void RewardHead(const torch::Tensor& h, DynamicsOutput& out);
  ModelConfig config;
  int64_t z_dim;
  // num_codes + 1 rows per level, the last the mask token: level l's code c is row
  // l * (num_codes + 1) + c. A cell's input is the sum of its levels' rows (RQ-Transformer).
  torch::nn::Embedding token_embed{nullptr};
  // [N, D], [T, D] (undefined with rotary time), [D]
  torch::Tensor spatial_pos, temporal_pos, action_start;
  torch::nn::Linear action_in{nullptr}, z_in{nullptr};
  StTransformer transformer{nullptr};
  // token_head: levels x K logits per cell, level-major (null when tied); each level's codes are
  // scored from the cell's output alone, independently of the other levels' codes.
  torch::nn::Linear token_head{nullptr}, reward_head{nullptr};
  torch::Tensor token_bias;  // [levels x K], the tied head's bias
  // model.copy_prior: the bonus added to the logit of the cell's previous code, per position and
  // level (weight zero, bias log(num_codes) at init, so every position starts at "copy").
  torch::nn::Linear copy_gate{nullptr};
  bool next_frame() const { return config.objective == "next_frame"; }
  bool rope_time() const { return config.temporal_positions == "rope"; }
  // Whether imagination can keep frames' temporal keys/values as the window slides
  // (train/rolling_imagination.h): one-pass decoding and keys that do not depend on the slot.
  bool can_roll() const { return next_frame() && rope_time(); }

 private:
  // The sum of each cell's level embeddings: tokens [B, T, levels x cells] -> [B, T, cells, D].
  torch::Tensor EmbedCodes(const torch::Tensor& tokens);
};
TORCH_MODULE(DynamicsNet);

struct WorldModelImpl : torch::nn::Module {
  explicit WorldModelImpl(const DynamicsConfig& config);

  // z_h for the dynamics: the prior's class probabilities [B, T, C*K], detached (the policy
  // embedding is trained by eq. 4 only; the dynamics consumes it). Undefined when off.
  torch::Tensor DynamicsZ(const torch::Tensor& tokens, const torch::Tensor& actions);
  // What the policy embedding reads of tokens [B, T, N]: the first level, [B, T, cells] (a
  // residual tokenizer's coarse codes; all of them with one level).
  torch::Tensor PolicyTokens(const torch::Tensor& tokens) const;
  // Teacher-forced losses over the whole segment (eq. 4 + eq. 5 + reward terms).
  WorldModelLosses Losses(const SegmentBatch& batch);
  // The raw forward: `tokens` [B, T, N] (mask token = num_codes allowed with "masked").
  DynamicsOutput Dynamics(const torch::Tensor& tokens, const torch::Tensor& actions,
                          const torch::Tensor& z);
  // Logits [B, N, num_codes] of the frame after the clean `context` [B, Tc, N] (Tc <
  // context_frames), actions [B, Tc, D] (the last leads to the new frame), z [B, Tc, z_dim]
  // (undefined without policy conditioning). "masked": the first MaskGIT round (the new frame
  // fully masked); "next_frame": the last position of the context. With "masked", `partial`
  // [B, N] (mask token where still unknown) replaces the fully masked frame.
  torch::Tensor NextFrameLogits(const torch::Tensor& context, const torch::Tensor& actions,
                                const torch::Tensor& z, const torch::Tensor& partial = {});

  DynamicsConfig config;
  DynamicsNet dynamics{nullptr};
  PolicyEmbedding policy{nullptr};  // null when model.policy_conditioning is false
};
TORCH_MODULE(WorldModel);

// MaskGIT's cosine schedule: fraction of tokens still masked at progress r in [0, 1].
torch::Tensor CosineMaskRatio(const torch::Tensor& r);

// Training masks from uniform noise. Frame t >= 1 is a target when u_frame[b, t] < frame_prob
// (the last frame also when no other is); a target masks ceil(cos(pi/2 * u_ratio[b, t]) * N)
// (at least 1) tokens, those with the smallest u_order[b, t, :]. Other frames stay clean context.
// u_ratio, u_frame [B, T], u_order [B, T, N] -> [B, T, N] bool.
torch::Tensor TrainingMask(const torch::Tensor& u_ratio, const torch::Tensor& u_order,
                           const torch::Tensor& u_frame, double frame_prob);

}  // namespace wm::train

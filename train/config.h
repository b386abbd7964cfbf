#pragma once
// DynamicsConfig: every knob of the action- and policy-conditioned ST-transformer dynamics
// model and its training run, loaded from YAML (configs/dynamics/*.yaml). Each field's meaning
// and default is documented in docs/dynamics.md; the defaults below are the `tiny` CPU preset.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

namespace wm::train {

struct ModelConfig {
  int grid_h = 8, grid_w = 8;       // cells per frame; must match the token data
  int num_codes = 1024;             // tokenizer codebook size; the embedding has num_codes + 1 rows
                                    // per level (the last is the MaskGIT mask token)
  int context_frames = 6;           // frames per training segment (T) = max frames in one forward
  int d_model = 128;                // transformer width (WHALE Table 6 "d_model")
  int num_layers = 4;               // ST blocks (Table 6 "num_layers")
  int num_heads = 4;                // attention heads (Table 6 "num_heads")
  int mlp_ratio = 4;                // MLP hidden = mlp_ratio * d_model
  std::string norm = "layernorm";   // pre-norm type: "layernorm" or "rmsnorm"
  bool policy_conditioning = true;  // WHALE eq. 4-5; false = the ablation without z
  bool action_conditioning = true;  // false = the action-blind control (actions zeroed)
  // true: token logits use the input embedding's rows (weight tying), so copying a code from the
  // previous frame needs no learned output map; false: a separate Linear head.
  bool tied_token_head = false;
  double mask_frame_prob = 0.5;  // chance that a frame j >= 1 is a masked target in training;
                                 // the others stay clean context (1 = every frame, as Genie)
  // "masked": MaskGIT (position j holds frame j partly masked + a_{j-1}, predicts its masked
  // tokens). "next_frame": teacher-forced and shifted (position j holds clean frame j + a_j and
  // predicts every token of frame j+1, as IRIS/STORM), decoded in one pass per frame.
  std::string objective = "masked";
  // A learned logit bonus for the code the same cell held in the previous frame, initialised so
  // that an untrained model predicts "copy the last frame"; training then only learns motion.
  bool copy_prior = false;
  // How the temporal attention knows when a frame is: "learned" (a vector per window slot, added
  // to the input) or "rope" (rotary, by frame index: only the distance between two frames
  // counts, so imagination can keep each frame's temporal keys/values as the window slides:
  // train/rolling_imagination.h). Stored in the checkpoint's config only when "rope".
  std::string temporal_positions = "learned";
  // How each ST block takes the frame's action (and z) besides the input embedding: "none", or
  // adaLN (DiT) with a per-frame shift, scale and gate of every sublayer, starting as the
  // unconditioned block ("identity") or as the identity ("zero", DiT's adaLN-Zero). Stored in
  // the checkpoint's config only when not "none".
  std::string adaptive_norm = "none";
  int decode_steps = 8;             // MaskGIT iterations per predicted frame at inference
  double decode_temperature = 1.0;  // sampling temperature at inference (0 = argmax)
  // Values per action the model takes (D). Not a YAML key: wm-train sets it from the token data
  // (the widest dataset of a mixture; narrower ones are zero-padded and masked). Stored in the
  // checkpoint's config as model.action_dim only when it is not 7, so 7-dim configs, hashes and
  // checkpoints keep their bytes and older checkpoints (without the key) load as 7.
  int action_dim = 7;
  // Codes per cell: a residual tokenizer's levels (tokenizer.levels of the token data). Not a YAML
  // key: wm-train sets it from the token data. A frame's tokens are level-major [levels, grid_h,
  // grid_w], as token datasets and the tokenizer hold them. Stored in the checkpoint's config as
  // model.levels only when it is not 1, so one-level configs, hashes and checkpoints keep their
  // bytes.
  int levels = 1;

  int64_t cells() const { return int64_t{grid_h} * grid_w; }
  int64_t tokens_per_frame() const { return levels * cells(); }
};

// The policy embedding model (WHALE Table 5; one width for posterior, prior and decoder).
struct PolicyConfig {
  int d_model = 32;
  int num_heads = 2;
  int posterior_layers = 1;  // q(z | tau_H): bidirectional over the whole segment
  int prior_layers = 1;      // p(z | tau_h): causal over the prefix
  int decoder_layers = 1;    // pi(a_h | o_h, tau_{h-1}, z): causal
  int categories = 16;       // z = categories x classes one-hots (Table 5 category/class size)
  int classes = 16;
  double log_std_min = -2.0;  // Gaussian policy head clamp (Table 5 "log_std")
  double log_std_max = 5.0;
  double kl_beta = 0.1;  // beta of WHALE eq. 4
};

struct TrainConfig {
  int batch_size = 8;  // global batch (split across data-parallel ranks)
  int64_t steps = 600;
  double max_lr = 1e-3;  // Table 7 uses 3e-5 for the 26M-456M models
  double min_lr = 1e-4;
  int64_t warmup_steps = 50;
  double beta1 = 0.9, beta2 = 0.9;
  double weight_decay = 0.0;     // Table 7
  double grad_clip = 1.0;        // max global L2 norm of the gradients (0 = off)
  double policy_weight = 1.0;    // weight of the policy-embedding loss (eq. 4) in the total
  double reward_weight = 1.0;    // weight of the reward MSE
  double terminal_weight = 0.1;  // weight of the terminal BCE
  bool bf16 = true;              // bf16 autocast on CUDA (ignored on CPU)
  uint64_t seed = 0;
  int threads = 1;  // LibTorch intra-op threads; fixed so CPU runs are reproducible
  int64_t checkpoint_every = 100;
  int64_t log_every = 10;   // metrics.csv row period
  int64_t val_every = 100;  // validation period when --val-tokens is given
  int val_batches = 2;      // fixed validation batches per evaluation
};

struct DataConfig {
  std::string mixture;  // configs/mixtures/*.yaml path; empty = datasets weighted by size
};

struct DynamicsConfig {
  ModelConfig model;
  PolicyConfig policy;
  TrainConfig train;
  DataConfig data;
};

// Parses and validates a YAML file. Unknown keys, wrong types and out-of-range values throw
// wm::Error naming the file and the key (e.g. "model.num_heads").
DynamicsConfig LoadDynamicsConfig(const std::string& path);
DynamicsConfig ParseDynamicsConfig(const std::string& yaml_text, const std::string& file);

// The config as JSON (for manifests and wm::ConfigHash), and back.
nlohmann::json ConfigToJson(const DynamicsConfig& config);
DynamicsConfig ConfigFromJson(const nlohmann::json& j);

// Throws wm::Error (key named, `file` attached) when a value is out of range.
void ValidateConfig(const DynamicsConfig& config, const std::string& file);

}  // namespace wm::train

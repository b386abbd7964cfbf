#pragma once
// TokenizerConfig: every knob of the VQ-VAE tokenizer and its training run, loaded from YAML
// (configs/tokenizer/*.yaml). Each field's meaning and default is documented in
// docs/tokenizer.md; the defaults below are the `tiny` CPU preset.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

namespace wm::tokenize {

struct ModelConfig {
  int image_size = 64;          // frames are resized (INTER_AREA) to image_size x image_size
  int patch_size = 8;           // total encoder downsampling (power of 2); tokens per side =
                                // image_size / patch_size
  int stem_factor = 1;          // pixel-unshuffle factor before the first conv (power of 2
                                // dividing patch_size; 1 = a full-resolution conv stem)
  std::string encoder = "conv";  // "conv": strided convs and residual blocks; "cell_local":
                                 // each token sees only its own patch (docs/tokenizer.md,
                                 // "Cell-local encoder")
  int encoder_channels = 64;    // conv width of the encoder (Table 4 "Encoder d_model")
  int encoder_layers = 1;       // residual blocks at token resolution (Table 4 "num_layers")
  int decoder_channels = 64;    // conv width of the decoder (Table 4 "Decoder d_model")
  int decoder_layers = 1;       // residual blocks at token resolution in the decoder
  int min_channels = 0;         // width halves per level above token resolution, down to this
                                // (0: constant width); cheap full-resolution layers on CPU
  int latent_dim = 32;          // code vector size
  int num_codes = 1024;         // codebook size (of each level)
  int levels = 1;               // residual VQ levels: codes per cell (docs/tokenizer.md,
                                // "Residual levels"); 1 = plain VQ
  bool l2_normalize = true;     // nearest code by cosine: latents and codes are L2-normalised
  double beta = 0.25;           // commitment weight
  int dead_code_steps = 100;    // a code unused for this many steps is re-seeded (0 = never)
  double detail_weight = 0;     // extra L1 weight on pixels far from their blurred frame (0: none)
  bool anchor_decoder = false;  // the decoder also sees an anchor: an earlier real frame of the
                                // episode (docs/tokenizer.md, "Anchor decoder")
  bool anchor_flow = false;     // with anchor_decoder: the anchor is moved by a learned flow
                                // before the correction is added ("Anchor flow")
  double change_weight = 0;     // with anchor_decoder: extra L1 weight on the pixels that changed
                                // since a real anchor by over 30 levels (0: none)
};

struct TrainConfig {
  int batch_size = 16;
  int64_t steps = 2000;
  double max_lr = 3e-4;
  double min_lr = 3e-5;        // cosine floor
  int64_t warmup_steps = 100;  // linear warmup from 0 to max_lr
  double beta1 = 0.9, beta2 = 0.9;
  double weight_decay = 1e-4;
  double grad_clip = 1.0;  // max global L2 norm of the gradients (0 = off)
  uint64_t seed = 0;
  int threads = 1;  // LibTorch intra-op threads; fixed so CPU runs are reproducible
  int64_t checkpoint_every = 500;
  int64_t log_every = 10;  // metrics.csv row period
  int64_t val_every = 0;   // val.csv period in steps with --val-data (0: only at the end)
  int val_frames = 64;     // validation frames (fixed, drawn once from the val data)
  // model.anchor_decoder: a frame at step t is decoded with the anchor t - k, k drawn in
  // [1, min(t, anchor_max_gap)]; with probability anchor_dropout (and always at t = 0) the anchor
  // is blank, so the tokens alone must describe the frame.
  int anchor_max_gap = 8;
  double anchor_dropout = 0.5;
};

struct DataConfig {
  std::string image_key = "image";  // Episode::images stream to train on
};

struct TokenizerConfig {
  ModelConfig model;
  TrainConfig train;
  DataConfig data;
};

// Parses and validates a YAML file. Unknown keys, wrong types and out-of-range values throw
// wm::Error naming the file and the key (e.g. "model.patch_size").
TokenizerConfig LoadTokenizerConfig(const std::string& path);
TokenizerConfig ParseTokenizerConfig(const std::string& yaml_text, const std::string& file);

// The config as JSON (for manifests and wm::ConfigHash), and back.
nlohmann::json ConfigToJson(const TokenizerConfig& config);
TokenizerConfig ConfigFromJson(const nlohmann::json& j);

// Throws wm::Error (key named, `file` attached) when a value is out of range.
void ValidateConfig(const TokenizerConfig& config, const std::string& file);

}  // namespace wm::tokenize

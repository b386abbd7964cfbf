#pragma once
// The small configs the dynamics tests share (fast on 2 cores).
#include "train/config.h"

namespace wm::train::test {

// 2x3 tokens, 16 codes, 4 frames, d 32 x 2 layers; policy d 16, z = 4 x 4.
inline DynamicsConfig TinyConfig(bool policy_conditioning) {
  DynamicsConfig c;
  c.model.grid_h = 2;
  c.model.grid_w = 3;
  c.model.num_codes = 16;
  c.model.context_frames = 4;
  c.model.d_model = 32;
  c.model.num_layers = 2;
  c.model.num_heads = 4;
  c.model.mlp_ratio = 2;
  c.model.policy_conditioning = policy_conditioning;
  c.model.decode_steps = 4;
  c.policy.d_model = 16;
  c.policy.num_heads = 2;
  c.policy.posterior_layers = 1;
  c.policy.prior_layers = 1;
  c.policy.decoder_layers = 1;
  c.policy.categories = 4;
  c.policy.classes = 4;
  c.train.threads = 1;
  return c;
}

}  // namespace wm::train::test

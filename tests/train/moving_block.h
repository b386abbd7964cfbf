#pragma once
// A learnable synthetic token dataset for the dynamics tests, benchmark and demo: on a
// grid_h x grid_w token grid a "block" (code 1 + episode % 7) sits on a textured background
// (codes >= 8, fixed per episode); action dx (sign) moves it one cell left/right, dy up/down.
// With `levels`, each frame holds that many codes per cell, level-major (token format version 3).
// Reward 1 and is_terminal on the step that moves the block onto the right edge (episode ends).
// Two scripted "policies" (policy_id) differ in how often they push right.
#include <cstdint>
#include <string>

namespace wm::train::test {

struct MovingBlockOptions {
  std::string dataset = "moving_block";
  int episodes = 12;
  int steps = 12;  // per episode, unless the block reaches the right edge earlier
  int grid_h = 4, grid_w = 4;
  int64_t num_codes = 32;
  uint64_t seed = 0;
  // true: dx and dy each uniform over {-1, 0, 1} whatever the policy, so where the block goes
  // next is only knowable from the action (the action-sensitivity check).
  bool uniform_moves = false;
  std::string tokenizer_sha256 = "moving-block-tokenizer";
  // Values per action: 7 writes the canonical eef_delta action; another width a
  // "joint_position" one with dx, dy first and the policy flag last (the rest 0).
  int action_dim = 7;
  // Codes per cell, as a residual tokenizer's levels: level l of the block's cell is
  // 1 + (episode + l) % 7, of a background cell a code >= 8 fixed per episode and level.
  int levels = 1;
};

// Writes a one-part token dataset (index.json + part-00000) into `dir`.
void WriteMovingBlockTokens(const std::string& dir, const MovingBlockOptions& options);

}  // namespace wm::train::test

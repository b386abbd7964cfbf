#include "tests/train/moving_block.h"

#include <random>

#include "core/episode.h"
#include "core/tokens/token_dataset.h"

namespace wm::train::test {

void WriteMovingBlockTokens(const std::string& dir, const MovingBlockOptions& o) {
  tokens::TokenIndex base;
  base.dataset = o.dataset;
  base.split = "train";
  base.tokenizer = {.checkpoint_sha256 = o.tokenizer_sha256,
                    .config_hash = "moving-block",
                    .num_codes = o.num_codes,
                    .grid_h = o.grid_h,
                    .grid_w = o.grid_w,
                    .levels = o.levels,
                    .image_size = 8 * o.grid_h};
  base.token_dtype = o.num_codes > 65536 ? "uint32" : "uint16";
  base.action_dim = o.action_dim;
  base.action_space = o.action_dim == kActionDim ? "eef_delta" : "joint_position";
  std::mt19937_64 rng(o.seed);
  auto uniform = [&] { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };
  const int N = o.grid_h * o.grid_w;
  std::vector<float> all_actions;
  tokens::TokenPartWriter writer(dir, 0, 1, base);
  for (int k = 0; k < o.episodes; ++k) {
    const bool eager = k % 2 == 0;  // policy "eager" pushes right more often
    std::vector<uint32_t> background(static_cast<size_t>(o.levels * N));  // [levels, N]
    for (auto& b : background) b = 8 + static_cast<uint32_t>(rng() % (o.num_codes - 8));
    int x = 0, y = static_cast<int>(rng() % o.grid_h);
    Episode e;
    e.episode_key = "block" + std::to_string(k);
    e.policy_id = eager ? "eager" : "wander";
    e.action_dim = o.action_dim;
    e.action_space = base.action_space;
    std::vector<uint32_t> frames;
    for (int t = 0; t < o.steps; ++t) {
      for (int l = 0; l < o.levels; ++l) {
        for (int i = 0; i < N; ++i) {
          frames.push_back(i == y * o.grid_w + x ? 1 + static_cast<uint32_t>((k + l) % 7)
                                                 : background[l * N + i]);
        }
      }
      const double u = uniform();
      int dx = u < (eager ? 0.6 : 0.3) ? 1 : (u < 0.8 ? 0 : -1);
      int dy = uniform() < 0.2 ? (uniform() < 0.5 ? -1 : 1) : 0;
      if (o.uniform_moves) {
        dx = static_cast<int>(rng() % 3) - 1;
        dy = static_cast<int>(rng() % 3) - 1;
      }
      std::vector<float> action(o.action_dim, 0.f);
      action[0] = 0.04f * dx;
      action[1] = 0.04f * dy;
      action.back() = eager ? 1.f : 0.f;
      e.actions.insert(e.actions.end(), action.begin(), action.end());
      x = std::clamp(x + dx, 0, o.grid_w - 1);
      y = std::clamp(y + dy, 0, o.grid_h - 1);
      const bool done = x == o.grid_w - 1 || t == o.steps - 1;
      e.rewards.push_back(x == o.grid_w - 1 ? 1.f : 0.f);
      e.discounts.push_back(1.f);
      e.is_first.push_back(t == 0);
      e.is_last.push_back(done);
      e.is_terminal.push_back(x == o.grid_w - 1);
      ++e.num_steps;
      if (done) break;
    }
    all_actions.insert(all_actions.end(), e.actions.begin(), e.actions.end());
    writer.AddEpisode({.num_frames = e.num_steps,
                       .source_episode = k,
                       .episode_key = e.episode_key,
                       .policy_id = e.policy_id},
                      frames, e);
  }
  writer.Finish();
  base.action_stats = shard::ComputeActionStats(all_actions, o.action_dim);
  tokens::AssembleIndexIfComplete(dir, 1, base);
}

}  // namespace wm::train::test

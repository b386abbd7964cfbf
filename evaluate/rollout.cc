#include "evaluate/rollout.h"

#include <algorithm>

#include "core/error.h"
#include "core/tokens/token_dataset.h"
#include "evaluate/retrace.h"
#include "train/dynamics_model.h"

namespace wm::evaluate {
namespace {

// SplitMix64 finaliser: one sampling seed per (run seed, step).
uint64_t StepSeed(uint64_t seed, int64_t step) {
  uint64_t x = seed ^ (0x9E3779B97F4A7C15ull * static_cast<uint64_t>(step + 1));
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// z of each episode from the prior over its first real frames and actions; empty without
// policy conditioning.
std::vector<std::vector<float>> PolicyEmbeddings(const train::DynamicsModel& model,
                                                 const tokens::TokenDataset& data,
                                                 const std::vector<int64_t>& episodes,
                                                 int64_t prefix) {
  std::vector<std::vector<float>> z;
  const int64_t n = data.tokens_per_frame();
  for (int64_t k : episodes) {
    const int64_t frames = std::clamp<int64_t>(
        prefix, 1, std::min<int64_t>(data.episode(k).num_frames, model.max_context_frames()));
    train::FrameContext c{.batch = 1, .frames = frames};
    c.tokens.resize(static_cast<size_t>(frames * n));
    data.CopyTokens(k, 0, frames, c.tokens.data());
    c.actions.assign(data.actions(k), data.actions(k) + frames * kActionDim);
    z.push_back(model.PolicyEmbedding(c));
  }
  return z;
}

}  // namespace

const char* RolloutName(RolloutMode mode) {
  return mode == RolloutMode::kPlain ? "plain" : "retrace";
}

std::vector<EpisodeRollout> Rollout(const train::DynamicsModel& model,
                                    const tokens::TokenDataset& data,
                                    const std::vector<int64_t>& episodes, RolloutMode mode,
                                    const RolloutOptions& o) {
  const int64_t n = data.tokens_per_frame();
  Check(n == model.tokens_per_frame() &&
            data.index().tokenizer.num_codes == model.config().model.num_codes,
        "the model was trained on " + std::to_string(model.tokens_per_frame()) + " tokens of " +
            std::to_string(model.config().model.num_codes) + " codes per frame; this data has " +
            std::to_string(n) + " of " + std::to_string(data.index().tokenizer.num_codes),
        {.file = data.dir()});
  const int64_t context =
      o.context > 0 ? std::min(o.context, model.max_context_frames()) : model.max_context_frames();
  const auto z = PolicyEmbeddings(model, data, episodes, o.policy_prefix);
  std::vector<EpisodeRollout> out;
  int64_t longest = 0;
  for (int64_t k : episodes) {
    EpisodeRollout r{.episode = k, .steps = std::min(o.horizon, data.episode(k).num_frames - 1)};
    std::vector<int64_t> first(static_cast<size_t>(n));
    data.CopyTokens(k, 0, 1, first.data());
    r.tokens.assign(o.samples, first);
    r.rewards.assign(o.samples, {});
    longest = std::max(longest, r.steps);
    out.push_back(std::move(r));
  }
  for (int64_t t = 0; t < longest; ++t) {
    // Rows: (episode still imagining, sample). Every row has the same slot layout at step t.
    std::vector<std::pair<size_t, int>> rows;
    for (size_t e = 0; e < out.size(); ++e) {
      for (int s = 0; s < o.samples && t < out[e].steps; ++s) rows.emplace_back(e, s);
    }
    train::FrameContext c{.batch = static_cast<int64_t>(rows.size())};
    for (auto [e, s] : rows) {
      const float* actions = data.actions(out[e].episode);
      auto slots = mode == RolloutMode::kPlain ? PlainContext(actions, t, context)
                                               : RetraceContext(actions, t, context);
      c.frames = static_cast<int64_t>(slots.size());
      for (const ContextSlot& slot : slots) {
        const auto& frames = out[e].tokens[s];
        c.tokens.insert(c.tokens.end(), frames.begin() + slot.frame * n,
                        frames.begin() + (slot.frame + 1) * n);
        c.actions.insert(c.actions.end(), slot.action.begin(), slot.action.end());
      }
      c.policy_z.insert(c.policy_z.end(), z[e].begin(), z[e].end());
    }
    std::vector<int64_t> next = model.PredictNextFrame(c, StepSeed(o.seed, t));  // [rows, N]
    // The reward of step t -> t+1 from the context extended by the new frame.
    train::FrameContext with_next = c;
    with_next.frames = c.frames + 1;
    with_next.tokens.clear();
    with_next.actions.clear();
    for (size_t r = 0; r < rows.size(); ++r) {
      const size_t span = static_cast<size_t>(c.frames * n);
      with_next.tokens.insert(with_next.tokens.end(), c.tokens.begin() + r * span,
                              c.tokens.begin() + (r + 1) * span);
      with_next.tokens.insert(with_next.tokens.end(), next.begin() + r * n,
                              next.begin() + (r + 1) * n);
      const size_t a = static_cast<size_t>(c.frames * kActionDim);
      with_next.actions.insert(with_next.actions.end(), c.actions.begin() + r * a,
                               c.actions.begin() + (r + 1) * a);
      with_next.actions.insert(with_next.actions.end(), kActionDim, 0.f);  // unused last action
    }
    train::RewardPrediction rewards = model.PredictRewards(with_next);
    for (size_t r = 0; r < rows.size(); ++r) {
      auto [e, s] = rows[r];
      out[e].tokens[s].insert(out[e].tokens[s].end(), next.begin() + r * n,
                              next.begin() + (r + 1) * n);
      out[e].rewards[s].push_back(rewards.reward[(r + 1) * c.frames - 1]);
    }
  }
  return out;
}

}  // namespace wm::evaluate

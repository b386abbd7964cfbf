#include "evaluate/rollout.h"

#include <algorithm>
#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/tokens/token_dataset.h"
#include "evaluate/retrace.h"
#include "train/dynamics_model.h"

namespace wm::evaluate {

uint64_t MixSeed(uint64_t seed, int64_t counter) {
  uint64_t x = seed ^ (0x9E3779B97F4A7C15ull * static_cast<uint64_t>(counter + 1));
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

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
    c.actions.assign(data.actions(k), data.actions(k) + frames * data.action_dim());
    z.push_back(model.PolicyEmbedding(c));
  }
  return z;
}

uint64_t ImaginationSeed(uint64_t seed, int64_t episode, int sample, int64_t step) {
  return MixSeed(MixSeed(MixSeed(seed, episode), sample), step);
}

int64_t ContextFrames(const train::DynamicsModel& model, int64_t requested) {
  return requested > 0 ? std::min(requested, model.max_context_frames())
                       : model.max_context_frames();
}

void AppendContextRow(const std::vector<int64_t>& frames, const std::vector<ContextSlot>& slots,
                      int64_t n, train::FrameContext& c) {
  c.frames = static_cast<int64_t>(slots.size());
  for (const ContextSlot& slot : slots) {
    c.tokens.insert(c.tokens.end(), frames.begin() + slot.frame * n,
                    frames.begin() + (slot.frame + 1) * n);
    c.actions.insert(c.actions.end(), slot.action.begin(), slot.action.end());
  }
}

train::FrameContext ImaginationContext(const train::DynamicsModel& model,
                                       const std::vector<int64_t>& frames,
                                       const std::vector<ContextSlot>& slots,
                                       const std::vector<float>& policy_z, uint64_t row_seed) {
  train::FrameContext c{.batch = 1};
  AppendContextRow(frames, slots, model.tokens_per_frame(), c);
  c.policy_z = policy_z;
  c.row_seeds = {row_seed};
  return c;
}

ImaginedFrame ImagineNextFrame(const train::DynamicsModel& model,
                               const std::vector<int64_t>& frames,
                               const std::vector<ContextSlot>& slots,
                               const std::vector<float>& policy_z, uint64_t row_seed,
                               const RolloutOptions& o) {
  train::FrameContext c = ImaginationContext(model, frames, slots, policy_z, row_seed);
  ImaginedFrame out;
  out.tokens = model.PredictNextFrame(c, 0, o.decode_steps, o.temperature);  // [N]
  // The reward and terminal flag of the new frame's step, from the context extended by it.
  c.frames += 1;
  c.tokens.insert(c.tokens.end(), out.tokens.begin(), out.tokens.end());
  c.actions.insert(c.actions.end(), model.action_dim(), 0.f);  // unused last action
  const train::RewardPrediction r = model.PredictRewards(c);
  out.reward = r.reward.back();
  out.terminal_prob = r.terminal_prob.back();
  return out;
}

namespace {

// "4 levels x 8x8 tokens of 1024 codes" (one level: "8x8 tokens of 1024 codes").
std::string TokenShape(int levels, int grid_h, int grid_w, int64_t codes) {
  return (levels == 1 ? "" : std::to_string(levels) + " levels x ") + std::to_string(grid_h) + "x" +
         std::to_string(grid_w) + " tokens of " + std::to_string(codes) + " codes";
}

}  // namespace

void CheckModelFitsTokens(const train::DynamicsModel& model, const tokens::TokenDataset& data) {
  const train::ModelConfig& m = model.config().model;
  const tokens::TokenizerInfo& t = data.index().tokenizer;
  Check(t.levels == m.levels && t.grid_h == m.grid_h && t.grid_w == m.grid_w &&
            t.num_codes == m.num_codes,
        "the model was trained on " + TokenShape(m.levels, m.grid_h, m.grid_w, m.num_codes) +
            " per frame; this data has " + TokenShape(t.levels, t.grid_h, t.grid_w, t.num_codes) +
            (t.levels != m.levels ? " (tokenizer.levels)" : ""),
        {.file = data.dir()});
  Check(model.action_dim() == data.action_dim(),
        "the model takes " + std::to_string(model.action_dim()) + "-dim actions of dataset '" +
            data.index().dataset + "'? this data's are " + std::to_string(data.action_dim()) +
            "-dim",
        {.file = data.dir()});
}

void CheckRolloutModeFits(RolloutMode mode, const tokens::TokenDataset& data) {
  const std::string& space = data.index().action_space;
  Check(mode != RolloutMode::kRetrace || space == "eef_delta",
        "retrace (WHALE eq. 6) sums end-effector deltas, but dataset '" + data.index().dataset +
            "' has " + space + " actions (use --rollout plain)",
        {.file = data.dir()});
}

std::vector<RolloutMode> AutoRolloutModes(const std::string& tokens_dir) {
  const std::string path = (std::filesystem::path(tokens_dir) / "index.json").string();
  const auto j = nlohmann::json::parse(ReadFile(path), nullptr, /*allow_exceptions=*/false);
  Check(!j.is_discarded(), "index.json is not valid JSON", {.file = path});
  if (tokens::TokenIndexFromJson(j, path).action_space == "eef_delta") {
    return {RolloutMode::kPlain, RolloutMode::kRetrace};
  }
  return {RolloutMode::kPlain};
}

const char* RolloutName(RolloutMode mode) {
  return mode == RolloutMode::kPlain ? "plain" : "retrace";
}

std::vector<EpisodeRollout> Rollout(const train::DynamicsModel& model,
                                    const tokens::TokenDataset& data,
                                    const std::vector<int64_t>& episodes, RolloutMode mode,
                                    const RolloutOptions& o,
                                    const std::vector<std::vector<float>>* actions_given,
                                    Progress* progress) {
  CheckModelFitsTokens(model, data);
  CheckRolloutModeFits(mode, data);
  const int64_t n = data.tokens_per_frame(), dim = data.action_dim();
  const int64_t context = ContextFrames(model, o.context);
  const auto z = PolicyEmbeddings(model, data, episodes, o.policy_prefix);
  std::vector<EpisodeRollout> out;
  for (int64_t k : episodes) {
    EpisodeRollout r{.episode = k, .steps = std::min(o.horizon, data.episode(k).num_frames - 1)};
    std::vector<int64_t> first(static_cast<size_t>(n));
    data.CopyTokens(k, 0, 1, first.data());
    r.tokens.assign(o.samples, first);
    r.rewards.assign(o.samples, {});
    out.push_back(std::move(r));
  }
  // One row (episode, sample) per model call: batched rows would change the last bits of the
  // reward head (CPU GEMM kernels depend on the row count), and sharded runs must reproduce
  // single ones exactly.
  for (EpisodeRollout& r : out) {
    const auto index = static_cast<size_t>(&r - out.data());
    const float* actions = actions_given ? (*actions_given)[index].data() : data.actions(r.episode);
    const auto& policy_z = z[index];
    for (int s = 0; s < o.samples; ++s) {
      std::vector<int64_t>& frames = r.tokens[s];
      for (int64_t t = 0; t < r.steps; ++t) {
        auto slots = mode == RolloutMode::kPlain ? PlainContext(actions, dim, t, context)
                                                 : RetraceContext(actions, dim, t, context);
        if (s == 0) r.contexts.push_back(slots);
        const ImaginedFrame next = ImagineNextFrame(model, frames, slots, policy_z,
                                                    ImaginationSeed(o.seed, r.episode, s, t), o);
        r.rewards[s].push_back(next.reward);
        frames.insert(frames.end(), next.tokens.begin(), next.tokens.end());
      }
    }
    if (progress) progress->Add(1);
  }
  return out;
}

}  // namespace wm::evaluate

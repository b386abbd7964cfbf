#pragma once
// Open-loop imagination against held-out episodes (WPE protocol): start from the episode's
// real first frame, feed its logged actions, and let the world model imagine `horizon` frames,
// with the plain sliding context or WHALE's retracing context (evaluate/retrace.h).
#include <cstdint>
#include <string>
#include <vector>

#include "evaluate/retrace.h"

namespace wm {
class Progress;
}
namespace wm::tokens {
class TokenDataset;
}
namespace wm::train {
class DynamicsModel;
struct FrameContext;
}  // namespace wm::train

namespace wm::evaluate {

enum class RolloutMode { kPlain, kRetrace };
const char* RolloutName(RolloutMode mode);  // "plain" / "retrace"

struct RolloutOptions {
  int64_t horizon = 16;       // imagined frames per episode (capped at episode length - 1)
  int64_t context = 0;        // context frames; 0 = the model's maximum
  int samples = 1;            // independent imaginations per episode (uncertainty)
  uint64_t seed = 0;          // MaskGIT sampling; deterministic on CPU
  double temperature = -1;    // MaskGIT sampling temperature; < 0: the checkpoint's, 0: argmax
  int decode_steps = 0;       // MaskGIT rounds per frame; 0: the checkpoint's
  int64_t policy_prefix = 4;  // real frames the prior sees to infer the episode's policy z
};

struct EpisodeRollout {
  int64_t episode = 0;  // index in the token dataset
  int64_t steps = 0;    // imagined frames H_e = min(horizon, num_frames - 1)
  // Per sample: tokens of frames 0..H_e ([(H_e + 1) * N]; frame 0 is the real one) and the
  // reward head's prediction for each imagined step ([H_e]).
  std::vector<std::vector<int64_t>> tokens;
  std::vector<std::vector<float>> rewards;
  std::vector<std::vector<ContextSlot>> contexts;  // per step: the context sample 0 was given
};

// Rolls out every episode in `episodes`, one (episode, sample) row at a time with its own
// sampling seed, so an episode's result does not depend on which other episodes are rolled out.
// `actions`, when given, holds per episode of `episodes` the actions ([num_frames, D]) to feed
// instead of the logged ones (controllability.h); the policy prior still sees the logged ones.
// `progress`, when given, advances by one per episode rolled out (all its samples).
// Throws wm::Error when the model and the token data disagree on grid, codebook or action width,
// and for a retracing rollout of actions that are not end-effector deltas.
std::vector<EpisodeRollout> Rollout(const train::DynamicsModel& model,
                                    const tokens::TokenDataset& data,
                                    const std::vector<int64_t>& episodes, RolloutMode mode,
                                    const RolloutOptions& options,
                                    const std::vector<std::vector<float>>* actions = nullptr,
                                    Progress* progress = nullptr);

// Throws wm::Error naming the token dataset when the model and the token data disagree on grid,
// codebook or action width.
void CheckModelFitsTokens(const train::DynamicsModel& model, const tokens::TokenDataset& data);

// Retracing (WHALE eq. 6) sums end-effector deltas: it throws a one-line wm::Error naming the
// dataset and its action space when `mode` is kRetrace and the data's actions are not eef_delta.
void CheckRolloutModeFits(RolloutMode mode, const tokens::TokenDataset& data);
// wm-eval --rollout auto: plain and retrace when the token dataset in `tokens_dir` has
// end-effector-delta actions, else plain only (reads its index.json).
std::vector<RolloutMode> AutoRolloutModes(const std::string& tokens_dir);

// SplitMix64 finaliser: a seed derived from (seed, counter), for independent random streams.
uint64_t MixSeed(uint64_t seed, int64_t counter);

// The MaskGIT sampling seed of one imagined frame: one per (run seed, episode, sample, step), so
// an episode's imagination does not depend on which other episodes share its batch or shard.
uint64_t ImaginationSeed(uint64_t seed, int64_t episode, int sample, int64_t step);

// The context frames the model is given: `requested` (0 = the model's maximum), at most that.
int64_t ContextFrames(const train::DynamicsModel& model, int64_t requested);

// One imagined frame and the reward head's view of the step that led to it.
struct ImaginedFrame {
  std::vector<int64_t> tokens;  // [N]
  float reward = 0;             // r_t of step t -> t+1, t = the last slot's frame
  float terminal_prob = 0;      // P(is_terminal_t)
};

// z of each episode from the prior over its first `prefix` real frames and actions (one per
// episode of `episodes`); empty vectors without policy conditioning.
std::vector<std::vector<float>> PolicyEmbeddings(const train::DynamicsModel& model,
                                                 const tokens::TokenDataset& data,
                                                 const std::vector<int64_t>& episodes,
                                                 int64_t prefix);

// Appends a row to `c` (c.batch rows are expected in the end): the frames and actions of the
// context `slots` of a rollout's frames so far (`frames`: [(t + 1) * n] tokens); sets c.frames.
void AppendContextRow(const std::vector<int64_t>& frames, const std::vector<ContextSlot>& slots,
                      int64_t n, train::FrameContext& c);

// The one-row model input of ImagineNextFrame: the context `slots` of `frames`, `policy_z` and
// the row's sampling seed.
train::FrameContext ImaginationContext(const train::DynamicsModel& model,
                                       const std::vector<int64_t>& frames,
                                       const std::vector<ContextSlot>& slots,
                                       const std::vector<float>& policy_z, uint64_t row_seed);

// Imagines the frame after the context `slots` (PlainContext / RetraceContext) of the rollout's
// frames so far (`frames`: [(t + 1) * N] tokens) with one model call for the frame and one for
// its reward. `policy_z` may be empty (the prior infers z from the context). Deterministic on CPU
// for a given `row_seed`.
ImaginedFrame ImagineNextFrame(const train::DynamicsModel& model,
                               const std::vector<int64_t>& frames,
                               const std::vector<ContextSlot>& slots,
                               const std::vector<float>& policy_z, uint64_t row_seed,
                               const RolloutOptions& options);

}  // namespace wm::evaluate

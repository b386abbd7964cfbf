#pragma once
// A policy rolled out inside the world model (WPE, wpe-policy-evaluation.txt Sec. 3): from a
// held-out episode's real first frame, the policy sees each imagined frame, decoded as a user of
// the model sees it, and its action drives the next imagined frame; each step's success score
// (a token model's reward head, or a success classifier on the frames of a motion model) and
// terminal probability decide how the episode ends. The loop is one (RunClosedLoop); what
// imagines is an ImaginedWorlds over several episodes stepped in lockstep (issue 21 item 7): the
// token and motion models imagine them as one batch (a row per episode), the policy answers one
// observation per episode and step (docs/policy-protocol.md: episodes interleave).
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "evaluate/frame_scores.h"
#include "evaluate/rollout.h"

namespace wm::policy {
class PolicyProcess;
}
namespace wm::tokenize {
class Tokenizer;
}
namespace wm::motion {
class MotionModel;
}
namespace wm::success {
class SuccessModel;
}

namespace wm::evaluate {

struct ClosedLoopOptions {
  // Policy steps (actions) per episode at most, as wm-sim-policy --max-steps: the reward head's
  // predictions for steps 0..horizon-1 cover the observations the simulator scores.
  int64_t horizon = 40;
  int rollouts = 1;  // rollouts per start, with distinct policy and sampling seeds
  // Starts imagined together, as rows of one batch. A row's frames depend on its batch only
  // through float rounding (docs/reports.md).
  int batch = 16;
  // Token models with rotary time: keep each imagined frame's temporal keys/values as the window
  // slides (DynamicsModel::StartRolling; 2 frame passes per step instead of context_frames).
  // The same frames as the window path until the window slides, its own semantics after.
  bool rolling_cache = false;
  bool clamp_tabletop = true;  // clamp actions to the tabletop world's limits, as the simulator
  // A step whose success score (predicted reward, or P(success) of a success classifier)
  // exceeds this is a success and ends the episode (the tabletop dataset logs reward 1 on
  // reaching the goal, else 0); a predicted terminal probability above terminal_threshold ends
  // it without success.
  double success_threshold = 0.5;
  double terminal_threshold = 0.5;
  // Context length, sampling seed, temperature and MaskGIT rounds (horizon and samples unused).
  RolloutOptions imagination;
};

// Where a closed-loop episode starts: a held-out episode's real first frame.
struct ClosedLoopStart {
  int64_t episode = 0;        // index in the token dataset; the protocol's episode id
  uint64_t episode_seed = 0;  // the policy's reset seed is derived from it (policy_seed.h)
  std::string instruction;
  std::vector<int64_t> first_tokens;  // [N]: the frame's tokens from the token dataset
  Clip first_frame;  // [1, 3, S, S]: the real frame, step 0's observation and the decode anchor
};

struct ClosedLoopRollout {
  int64_t episode = 0;
  int rollout = 0;
  uint64_t episode_seed = 0, policy_seed = 0;
  int64_t steps = 0;                           // actions taken = imagined frames
  std::vector<float> actions;                  // [steps, D], as the model got them (clamped)
  std::vector<float> rewards, terminal_probs;  // [steps]: the success score of each step
  Clip frames;                // frame 0 (real) and the imagined frames 1..steps, decoded
  bool success = false;       // some step's success score > success_threshold
  double episode_return = 0;  // sum of the success scores
  std::string end;            // "success", "terminal" or "horizon"
};

// What a world model says of one closed-loop step.
struct ImaginedStep {
  Clip frame;               // [1, 3, S, S] in [-1, 1]: imagined frame t + 1, as the policy sees it
  float reward = 0;         // success score: predicted reward, or P(success | frame)
  float terminal_prob = 0;  // P(episode over); 0 for a model without a terminal head
};

// A world model's side of one closed-loop episode, holding its imagination so far.
class ImaginedWorld {
 public:
  virtual ~ImaginedWorld() = default;
  // Imagined frame t + 1 after actions rows 0..t ([(t + 1) * D], as the model gets them).
  virtual ImaginedStep Next(const std::vector<float>& actions, int64_t t) = 0;
};
// A fresh world for rollout `rollout` of `start`.
using WorldFactory =
    std::function<std::unique_ptr<ImaginedWorld>(const ClosedLoopStart& start, int rollout)>;

// Several closed-loop episodes imagined in lockstep, a row each, holding their imagination so far.
class ImaginedWorlds {
 public:
  virtual ~ImaginedWorlds() = default;
  // Imagined frame t + 1 of each row in `rows` (those still running, ascending), given
  // *actions[k] for rows[k]: its actions rows 0..t ([(t + 1) * D], as the model gets them).
  virtual std::vector<ImaginedStep> Next(const std::vector<size_t>& rows,
                                         const std::vector<const std::vector<float>*>& actions,
                                         int64_t t) = 0;
};
// Fresh worlds for rollout `rollout` of each of `starts` (row k: starts[k]).
using WorldsFactory = std::function<std::unique_ptr<ImaginedWorlds>(
    const std::vector<const ClosedLoopStart*>& starts, int rollout)>;

// One world per row, stepped one after another: what any ImaginedWorld imagines, in lockstep.
WorldsFactory WorldsInTurn(WorldFactory worlds);

// Rolls out `policy` from each of `starts` (rollout `rollout` of each) in `worlds`, all in
// lockstep: every start's episode is reset, then each step asks the policy for every running
// episode in turn and imagines their frames together. An episode ends as in RunClosedLoop; its
// rollout is what RunClosedLoop gives with the same world (row k is starts[k]'s).
std::vector<ClosedLoopRollout> RunClosedLoops(ImaginedWorlds& worlds, policy::PolicyProcess& policy,
                                              const std::vector<const ClosedLoopStart*>& starts,
                                              int rollout, const ClosedLoopOptions& options);

// Rolls out `policy` in `world` from `start` (rollout `rollout` of it). The policy is reset with
// RolloutPolicySeed(start.episode_seed, rollout) and asked at steps 0..; step 0 shows the real
// first frame, step t > 0 imagined frame t. A policy failure throws the policy's wm::Error
// (naming policy, episode and step).
ClosedLoopRollout RunClosedLoop(ImaginedWorld& world, policy::PolicyProcess& policy,
                                const ClosedLoopStart& start, int rollout,
                                const ClosedLoopOptions& options);

// The token dynamics model: frames decoded with the real first frame as anchor, the reward and
// terminal heads score each step. Sampling seeds are ImaginationSeed(seed, episode, rollout,
// step): byte-reproducible on CPU. One episode at a time, each step recomputing the whole
// context window twice (the frame, then its reward): the reference TokenWorldBatches is checked
// against (bench/imagination_bench.cc; the model step it relies on, DynamicsModel::ImagineStep,
// by tests/train/imagine_step_test.cc).
WorldFactory TokenWorlds(const train::DynamicsModel& model, const tokenize::Tokenizer& tok,
                         const ClosedLoopOptions& options);
// The same worlds imagined as one batch: a model call (DynamicsModel::ImagineStep: the window
// encoded once, its temporal keys/values reused for the reward) and one tokenizer decode per
// step for all rows. Equal to TokenWorlds up to float rounding: the same seeds, so the same
// frames unless a sampled token or a threshold sits within rounding of a tie (docs/reports.md).
WorldsFactory TokenWorldBatches(const train::DynamicsModel& model, const tokenize::Tokenizer& tok,
                                const ClosedLoopOptions& options);

// `worlds` judged by a success classifier trained on real frames: each step's success score
// becomes the classifier's P(success | the imagined frame), one call per step for the running
// rows, and there is no terminal head (evaluate/success_scored_worlds.cc). The motion model's
// only judge; for a token model (wm-eval --policy --success-model) it replaces the reward head,
// so the two kinds of model are judged alike.
WorldsFactory ScoredBySuccess(WorldsFactory worlds, const success::SuccessModel& success);

// The motion model (deterministic: every rollout of a start imagines the same under the same
// actions), each imagined frame scored by the success classifier's P(success); no terminal
// head (evaluate/motion_closed_loop.cc). One episode at a time: the reference
// MotionWorldBatches is checked against (tests/evaluate/motion_closed_loop_test.cc,
// bench/motion_imagination_bench.cc).
WorldFactory MotionWorlds(const motion::MotionModel& model, const success::SuccessModel& success);
// The same worlds imagined as one batch: the starts are the rows of one MotionModel::Rollout and
// each step's frames are scored by one classifier call. Equal to MotionWorlds up to float
// rounding (other conv/GEMM shapes; docs/reports.md).
WorldsFactory MotionWorldBatches(const motion::MotionModel& model,
                                 const success::SuccessModel& success);

}  // namespace wm::evaluate

#include "evaluate/closed_loop.h"

#include <numeric>

#include "policy/action_limits.h"
#include "policy/policy_process.h"
#include "policy/policy_seed.h"
#include "tokenize/tokenizer.h"

namespace wm::evaluate {
namespace {

// Each row its own world, stepped in turn; the worlds are owned, or one borrowed.
class WorldsOneByOne : public ImaginedWorlds {
 public:
  explicit WorldsOneByOne(std::vector<std::unique_ptr<ImaginedWorld>> worlds)
      : owned_(std::move(worlds)) {
    for (const auto& w : owned_) worlds_.push_back(w.get());
  }
  explicit WorldsOneByOne(ImaginedWorld& world) : worlds_{&world} {}

  std::vector<ImaginedStep> Next(const std::vector<size_t>& rows,
                                 const std::vector<const std::vector<float>*>& actions,
                                 int64_t t) override {
    std::vector<ImaginedStep> out;
    for (size_t k = 0; k < rows.size(); ++k) out.push_back(worlds_[rows[k]]->Next(*actions[k], t));
    return out;
  }

 private:
  std::vector<std::unique_ptr<ImaginedWorld>> owned_;
  std::vector<ImaginedWorld*> worlds_;
};

// A rollout of `start` before its first step, its policy reset.
ClosedLoopRollout StartRollout(policy::PolicyProcess& policy, const ClosedLoopStart& start,
                               int rollout) {
  ClosedLoopRollout r{.episode = start.episode,
                      .rollout = rollout,
                      .episode_seed = start.episode_seed,
                      .policy_seed = policy::RolloutPolicySeed(start.episode_seed, rollout),
                      .frames = start.first_frame,
                      .end = "horizon"};
  policy.Reset(start.episode, r.policy_seed, start.instruction);
  return r;
}

// The policy's action at step t, seeing the last frame of `r` (clamped as the options say),
// appended to r.actions.
void Act(policy::PolicyProcess& policy, const ClosedLoopStart& start, int64_t t,
         const ClosedLoopOptions& o, ClosedLoopRollout& r) {
  const int size = start.first_frame.size;
  const std::vector<uint8_t> rgb = tokenize::PlanarToRgb8(r.frames.frame(t), size);
  std::vector<float> action =
      policy.Act({rgb.data(), size, size, start.instruction, start.episode, t});
  if (o.clamp_tabletop) policy::ClampTabletopAction(action.data());
  r.actions.insert(r.actions.end(), action.begin(), action.end());
}

// Records step t's imagined frame in `r`; whether the episode goes on.
bool Record(const ImaginedStep& next, int64_t t, const ClosedLoopOptions& o, ClosedLoopRollout& r) {
  r.rewards.push_back(next.reward);
  r.terminal_probs.push_back(next.terminal_prob);
  r.episode_return += next.reward;
  r.steps = t + 1;
  r.frames.pixels.insert(r.frames.pixels.end(), next.frame.pixels.begin(), next.frame.pixels.end());
  r.frames.frames += 1;
  if (next.reward > o.success_threshold) {
    r.success = true, r.end = "success";
    return false;
  }
  if (next.terminal_prob > o.terminal_threshold) {
    r.end = "terminal";
    return false;
  }
  return true;
}

}  // namespace

WorldsFactory WorldsInTurn(WorldFactory worlds) {
  return [worlds = std::move(worlds)](const std::vector<const ClosedLoopStart*>& starts,
                                      int rollout) -> std::unique_ptr<ImaginedWorlds> {
    std::vector<std::unique_ptr<ImaginedWorld>> each;
    for (const ClosedLoopStart* s : starts) each.push_back(worlds(*s, rollout));
    return std::make_unique<WorldsOneByOne>(std::move(each));
  };
}

std::vector<ClosedLoopRollout> RunClosedLoops(ImaginedWorlds& worlds, policy::PolicyProcess& policy,
                                              const std::vector<const ClosedLoopStart*>& starts,
                                              int rollout, const ClosedLoopOptions& o) {
  std::vector<ClosedLoopRollout> out;
  for (const ClosedLoopStart* s : starts) out.push_back(StartRollout(policy, *s, rollout));
  std::vector<size_t> running(starts.size());
  std::iota(running.begin(), running.end(), size_t{0});
  for (int64_t t = 0; t < o.horizon && !running.empty(); ++t) {
    std::vector<const std::vector<float>*> actions;
    for (size_t k : running) {
      Act(policy, *starts[k], t, o, out[k]);
      actions.push_back(&out[k].actions);
    }
    const std::vector<ImaginedStep> next = worlds.Next(running, actions, t);
    std::vector<size_t> still_running;
    for (size_t i = 0; i < running.size(); ++i) {
      if (Record(next[i], t, o, out[running[i]])) still_running.push_back(running[i]);
    }
    running = std::move(still_running);
  }
  return out;
}

ClosedLoopRollout RunClosedLoop(ImaginedWorld& world, policy::PolicyProcess& policy,
                                const ClosedLoopStart& start, int rollout,
                                const ClosedLoopOptions& o) {
  WorldsOneByOne one(world);
  return RunClosedLoops(one, policy, {&start}, rollout, o).front();
}

}  // namespace wm::evaluate

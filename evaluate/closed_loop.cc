#include "evaluate/closed_loop.h"

#include "core/episode.h"
#include "evaluate/clip_decode.h"
#include "evaluate/retrace.h"
#include "policy/action_limits.h"
#include "policy/policy_process.h"
#include "policy/policy_seed.h"
#include "tokenize/tokenizer.h"
#include "train/dynamics_model.h"

namespace wm::evaluate {

ClosedLoopRollout ImagineClosedLoop(const train::DynamicsModel& model,
                                    const tokenize::Tokenizer& tok, policy::PolicyProcess& policy,
                                    const ClosedLoopStart& start, int rollout,
                                    const ClosedLoopOptions& o) {
  const int size = start.first_frame.size;
  const int64_t context = ContextFrames(model, o.imagination.context);
  ClosedLoopRollout r{.episode = start.episode,
                      .rollout = rollout,
                      .episode_seed = start.episode_seed,
                      .policy_seed = policy::RolloutPolicySeed(start.episode_seed, rollout),
                      .tokens = start.first_tokens,
                      .frames = start.first_frame,
                      .end = "horizon"};
  policy.Reset(start.episode, r.policy_seed, start.instruction);
  for (int64_t t = 0; t < o.horizon; ++t) {
    const std::vector<uint8_t> rgb = tokenize::PlanarToRgb8(r.frames.frame(t), size);
    std::vector<float> action =
        policy.Act({rgb.data(), size, size, start.instruction, start.episode, t});
    if (o.clamp_tabletop) policy::ClampTabletopAction(action.data());
    r.actions.insert(r.actions.end(), action.begin(), action.end());
    // The policy z is left to the prior, which infers it from this rollout's own context.
    const ImaginedFrame next = ImagineNextFrame(
        model, r.tokens, PlainContext(r.actions.data(), model.action_dim(), t, context), {},
        ImaginationSeed(o.imagination.seed, start.episode, rollout, t), o.imagination);
    r.tokens.insert(r.tokens.end(), next.tokens.begin(), next.tokens.end());
    r.rewards.push_back(next.reward);
    r.terminal_probs.push_back(next.terminal_prob);
    r.episode_return += next.reward;
    r.steps = t + 1;
    const Clip decoded = DecodeClip(tok, r.tokens, t + 1, 1, start.first_frame);
    r.frames.pixels.insert(r.frames.pixels.end(), decoded.pixels.begin(), decoded.pixels.end());
    r.frames.frames += 1;
    if (next.reward > o.success_threshold) {
      r.success = true, r.end = "success";
      break;
    }
    if (next.terminal_prob > o.terminal_threshold) {
      r.end = "terminal";
      break;
    }
  }
  return r;
}

}  // namespace wm::evaluate

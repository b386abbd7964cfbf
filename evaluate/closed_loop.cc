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
namespace {

// The token model's imagination of one episode: the tokens so far, frame 0's the real ones.
class TokenWorld : public ImaginedWorld {
 public:
  TokenWorld(const train::DynamicsModel& model, const tokenize::Tokenizer& tok,
             const ClosedLoopStart& start, int rollout, const ClosedLoopOptions& o)
      : model_(model),
        tok_(tok),
        start_(start),
        rollout_(rollout),
        o_(o),
        context_(ContextFrames(model, o.imagination.context)),
        tokens_(start.first_tokens) {}

  ImaginedStep Next(const std::vector<float>& actions, int64_t t) override {
    // The policy z is left to the prior, which infers it from this rollout's own context.
    const ImaginedFrame next = ImagineNextFrame(
        model_, tokens_, PlainContext(actions.data(), model_.action_dim(), t, context_), {},
        ImaginationSeed(o_.imagination.seed, start_.episode, rollout_, t), o_.imagination);
    tokens_.insert(tokens_.end(), next.tokens.begin(), next.tokens.end());
    return {.frame = DecodeClip(tok_, tokens_, t + 1, 1, start_.first_frame),
            .reward = next.reward,
            .terminal_prob = next.terminal_prob};
  }

 private:
  const train::DynamicsModel& model_;
  const tokenize::Tokenizer& tok_;
  const ClosedLoopStart& start_;
  const int rollout_;
  const ClosedLoopOptions& o_;
  const int64_t context_;
  std::vector<int64_t> tokens_;  // [(t + 1) * N]
};

}  // namespace

ClosedLoopRollout RunClosedLoop(ImaginedWorld& world, policy::PolicyProcess& policy,
                                const ClosedLoopStart& start, int rollout,
                                const ClosedLoopOptions& o) {
  const int size = start.first_frame.size;
  ClosedLoopRollout r{.episode = start.episode,
                      .rollout = rollout,
                      .episode_seed = start.episode_seed,
                      .policy_seed = policy::RolloutPolicySeed(start.episode_seed, rollout),
                      .frames = start.first_frame,
                      .end = "horizon"};
  policy.Reset(start.episode, r.policy_seed, start.instruction);
  for (int64_t t = 0; t < o.horizon; ++t) {
    const std::vector<uint8_t> rgb = tokenize::PlanarToRgb8(r.frames.frame(t), size);
    std::vector<float> action =
        policy.Act({rgb.data(), size, size, start.instruction, start.episode, t});
    if (o.clamp_tabletop) policy::ClampTabletopAction(action.data());
    r.actions.insert(r.actions.end(), action.begin(), action.end());
    const ImaginedStep next = world.Next(r.actions, t);
    r.rewards.push_back(next.reward);
    r.terminal_probs.push_back(next.terminal_prob);
    r.episode_return += next.reward;
    r.steps = t + 1;
    r.frames.pixels.insert(r.frames.pixels.end(), next.frame.pixels.begin(),
                           next.frame.pixels.end());
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

WorldFactory TokenWorlds(const train::DynamicsModel& model, const tokenize::Tokenizer& tok,
                         const ClosedLoopOptions& options) {
  return [&model, &tok, &options](const ClosedLoopStart& start, int rollout) {
    return std::make_unique<TokenWorld>(model, tok, start, rollout, options);
  };
}

}  // namespace wm::evaluate

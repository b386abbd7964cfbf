// The token dynamics model in closed loop: TokenWorlds (one episode at a time, the reference) and
// TokenWorldBatches (the episodes of a batch as rows of one model call and one decode per step).
#include <memory>

#include "core/error.h"
#include "evaluate/clip_decode.h"
#include "evaluate/closed_loop.h"
#include "evaluate/retrace.h"
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

// TokenWorld's imagination for a batch of starts, a row each, all at the same step.
class TokenBatch : public ImaginedWorlds {
 public:
  TokenBatch(const train::DynamicsModel& model, const tokenize::Tokenizer& tok,
             const std::vector<const ClosedLoopStart*>& starts, int rollout,
             const ClosedLoopOptions& o)
      : model_(model),
        tok_(tok),
        starts_(starts),
        rollout_(rollout),
        o_(o),
        context_(ContextFrames(model, o.imagination.context)) {
    for (const ClosedLoopStart* s : starts) tokens_.push_back(s->first_tokens);
    Check(!o.rolling_cache || context_ == model.max_context_frames(),
          "a rolling cache imagines with the model's whole window (" +
              std::to_string(model.max_context_frames()) + " frames), not a context of " +
              std::to_string(context_));
  }

  std::vector<ImaginedStep> Next(const std::vector<size_t>& rows,
                                 const std::vector<const std::vector<float>*>& actions,
                                 int64_t t) override {
    const train::ImaginedSteps next =
        o_.rolling_cache ? RollingStep(rows, actions, t) : WindowStep(rows, actions, t);
    const std::vector<float> pixels = DecodeFrames(rows, next.tokens);
    const int size = tok_.image_size();
    const size_t n = next.tokens.size() / rows.size(), frame_size = pixels.size() / rows.size();
    std::vector<ImaginedStep> out;
    for (size_t k = 0; k < rows.size(); ++k) {
      std::vector<int64_t>& tokens = tokens_[rows[k]];
      tokens.insert(tokens.end(), next.tokens.begin() + k * n, next.tokens.begin() + (k + 1) * n);
      out.push_back(
          {.frame = {1,
                     size,
                     {pixels.begin() + k * frame_size, pixels.begin() + (k + 1) * frame_size}},
           .reward = next.reward[k],
           .terminal_prob = next.terminal_prob[k]});
    }
    return out;
  }

 private:
  std::vector<uint64_t> RowSeeds(const std::vector<size_t>& rows, int64_t t) const {
    std::vector<uint64_t> seeds;
    for (size_t row : rows) {
      seeds.push_back(ImaginationSeed(o_.imagination.seed, starts_[row]->episode, rollout_, t));
    }
    return seeds;
  }

  // The step with the context window encoded anew (DynamicsModel::ImagineStep).
  train::ImaginedSteps WindowStep(const std::vector<size_t>& rows,
                                  const std::vector<const std::vector<float>*>& actions,
                                  int64_t t) const {
    train::FrameContext c{.batch = static_cast<int64_t>(rows.size()),
                          .row_seeds = RowSeeds(rows, t)};
    for (size_t k = 0; k < rows.size(); ++k) {
      const std::vector<ContextSlot> slots =
          PlainContext(actions[k]->data(), model_.action_dim(), t, context_);
      AppendContextRow(tokens_[rows[k]], slots, model_.tokens_per_frame(), c);
    }
    return model_.ImagineStep(c, 0, o_.imagination.decode_steps, o_.imagination.temperature);
  }

  // The step with every frame's temporal keys/values kept (DynamicsModel::StartRolling).
  train::ImaginedSteps RollingStep(const std::vector<size_t>& rows,
                                   const std::vector<const std::vector<float>*>& actions,
                                   int64_t t) {
    if (!rolling_) {
      std::vector<int64_t> first;
      for (const ClosedLoopStart* s : starts_)
        first.insert(first.end(), s->first_tokens.begin(), s->first_tokens.end());
      rolling_ = model_.StartRolling(first, static_cast<int64_t>(starts_.size()));
    }
    // Each row's actions so far, [(t + 1) * D]: the newest frame's is the last.
    const auto D = static_cast<size_t>(model_.action_dim());
    std::vector<float> step_actions;
    for (const std::vector<float>* a : actions) {
      Check(a->size() == static_cast<size_t>(t + 1) * D,
            "closed loop: expected the actions of steps 0.." + std::to_string(t));
      step_actions.insert(step_actions.end(), a->end() - D, a->end());
    }
    return rolling_->Step({rows.begin(), rows.end()}, step_actions, RowSeeds(rows, t),
                          o_.imagination.temperature);
  }

  // One decode of the new frames ([rows, N]), each anchored on its start's real first frame.
  std::vector<float> DecodeFrames(const std::vector<size_t>& rows,
                                  const std::vector<int64_t>& frames) const {
    std::vector<float> anchors;
    for (size_t row : rows) {
      const Clip& given = starts_[row]->first_frame;
      const Clip last = RepeatFrame(given, given.frames - 1, 1);
      anchors.insert(anchors.end(), last.pixels.begin(), last.pixels.end());
    }
    const std::vector<uint32_t> codes(frames.begin(), frames.end());
    return tok_.Decode(codes.data(), static_cast<int64_t>(rows.size()), anchors.data());
  }

  const train::DynamicsModel& model_;
  const tokenize::Tokenizer& tok_;
  const std::vector<const ClosedLoopStart*> starts_;
  const int rollout_;
  const ClosedLoopOptions& o_;
  const int64_t context_;
  std::vector<std::vector<int64_t>> tokens_;            // per row: [(t + 1) * N]
  std::unique_ptr<train::RollingImagination> rolling_;  // with o.rolling_cache, from step 0
};

}  // namespace

WorldFactory TokenWorlds(const train::DynamicsModel& model, const tokenize::Tokenizer& tok,
                         const ClosedLoopOptions& options) {
  return [&model, &tok, &options](const ClosedLoopStart& start, int rollout) {
    return std::make_unique<TokenWorld>(model, tok, start, rollout, options);
  };
}

WorldsFactory TokenWorldBatches(const train::DynamicsModel& model, const tokenize::Tokenizer& tok,
                                const ClosedLoopOptions& options) {
  return [&model, &tok, &options](const std::vector<const ClosedLoopStart*>& starts,
                                  int rollout) -> std::unique_ptr<ImaginedWorlds> {
    return std::make_unique<TokenBatch>(model, tok, starts, rollout, options);
  };
}

}  // namespace wm::evaluate

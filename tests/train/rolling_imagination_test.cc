// Rotary time, the band-limited temporal attention and rolling imagination
// (train/rolling_imagination.h): until the window slides, the rolling path imagines what the
// window path (DecodeNextFrame + the reward of the extended window) imagines; after, its frames
// are the band-masked forward over the whole history; a row's rollout does not depend on the rest
// of its batch. Tolerance: float rounding of other GEMM shapes (1e-5 at unit scale).
#include "train/rolling_imagination.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "core/error.h"
#include "tests/train/test_config.h"
#include "train/batch.h"
#include "train/world_model.h"

namespace wm::train {
namespace {

constexpr double kTolerance = 1e-5;

void ExpectClose(const torch::Tensor& a, const torch::Tensor& b, const std::string& what) {
  ASSERT_EQ(a.sizes(), b.sizes()) << what;
  EXPECT_LT((a - b).abs().max().item<double>(), kTolerance) << what;
}

TEST(RotateByFrame, ScoresDependOnTheDistanceOnly) {
  torch::manual_seed(2);
  const torch::Tensor q = torch::randn({1, 2, 1, 8}), k = torch::randn({1, 2, 1, 8});
  EXPECT_TRUE(torch::allclose(RotateByFrame(q, 0), q));  // angle 0
  auto score = [&](int64_t i, int64_t j) {
    return (RotateByFrame(q, i) * RotateByFrame(k, j)).sum(-1);
  };
  ExpectClose(score(3, 1), score(40, 38), "same distance, other frames");
  EXPECT_GT((score(3, 1) - score(3, 2)).abs().max().item<double>(), 1e-3) << "distance counts";
  // By hand, the first pair (dims 0 and 4) turns by frame index x 1 rad (frequency 10000^0).
  const torch::Tensor r = RotateByFrame(q, 1);
  EXPECT_NEAR(
      r[0][0][0][0].item<double>(),
      q[0][0][0][0].item<double>() * std::cos(1.0) - q[0][0][0][4].item<double>() * std::sin(1.0),
      1e-6);
  EXPECT_TRUE(torch::allclose(RotateByFrame(q.expand({1, 2, 3, 8}), 5).select(2, 2),
                              RotateByFrame(q, 7).select(2, 0)));  // frame first + l
}

TEST(TimeAxis, ASpanHidesOlderFrames) {
  torch::manual_seed(3);
  StTransformer t(StBlockOptions{.dim = 16, .heads = 2, .mlp_ratio = 2, .rope_time = true}, 2);
  torch::NoGradGuard no_grad;
  const torch::Tensor x = torch::randn({2, 5, 3, 16});
  EXPECT_TRUE(torch::equal(t->Forward(x, {.span = 5}), t->forward(x)));  // no frame hidden
  // Span 1: each frame on its own (at its own index: rotary time moves nothing alone).
  const torch::Tensor alone = t->Forward(x, {.span = 1});
  for (int64_t f = 0; f < 5; ++f) {
    ExpectClose(alone.slice(1, f, f + 1), t->forward(x.slice(1, f, f + 1)),
                "frame " + std::to_string(f));
  }
  // Rotary time: shifting every frame's index changes nothing.
  ExpectClose(t->Forward(x, {.first = 17}), t->forward(x), "shifted indices");
}

// A random rope model, first frames [B, N] and per-step actions [steps, B, D].
struct Case {
  WorldModel m{nullptr};
  torch::Tensor first, actions;
};

// copy_prior: an untrained copy prior puts the previous code far on top, so frames would not
// show a wrong attention span; the tests that compare frames leave it off. With adaptive norm
// the zero-initialised modulation gets random weights, so the frames' conditioning counts.
Case MakeCase(bool policy, int64_t B, int64_t steps, bool copy_prior = false,
              const std::string& adaptive_norm = "none") {
  DynamicsConfig c = test::TinyConfig(policy);
  c.model.objective = "next_frame";
  c.model.copy_prior = copy_prior;
  c.model.temporal_positions = "rope";
  c.model.adaptive_norm = adaptive_norm;
  torch::manual_seed(7);
  Case k{WorldModel(c)};
  {
    torch::NoGradGuard no_grad;
    for (auto& p : k.m->named_parameters()) {
      if (p.key().find("modulation") != std::string::npos) p.value().normal_(0.0, 0.1);
    }
  }
  k.m->eval();
  k.first = torch::randint(c.model.num_codes, {B, 6}, torch::kInt64);
  k.actions = torch::randn({steps, B, 7});
  return k;
}

struct Rollout {
  torch::Tensor frames;            // [B, steps + 1, N]
  torch::Tensor reward, terminal;  // [B, steps]
  torch::Tensor log_probs;         // [B, steps, N, K]: what each frame was sampled from
};

std::vector<uint64_t> Seeds(int64_t t, int64_t B) {
  std::vector<uint64_t> s;
  for (int64_t b = 0; b < B; ++b) s.push_back(100 * t + b);
  return s;
}

Rollout Roll(Case& k, int64_t steps, double temperature) {
  const int64_t B = k.first.size(0);
  RollingWindow rolling(k.m, k.first);
  const torch::Tensor rows = torch::arange(B);
  std::vector<torch::Tensor> frames{k.first}, rewards, terminals, log_probs;
  for (int64_t t = 0; t < steps; ++t) {
    DynamicsOutput r;
    torch::Tensor lp;
    frames.push_back(rolling.Step(rows, k.actions[t], temperature, Seeds(t, B), r, &lp));
    rewards.push_back(r.reward), terminals.push_back(r.terminal_logit), log_probs.push_back(lp);
  }
  return {torch::stack(frames, 1), torch::stack(rewards, 1), torch::stack(terminals, 1),
          torch::stack(log_probs, 1)};
}

TEST(RollingWindow, ImaginesWhatTheWindowPathDoesUntilTheWindowSlides) {
  for (const auto& [policy, norm] : {std::pair{true, "none"}, {false, "none"}, {true, "zero"}}) {
    // context_frames 4: the window (3 frames) is full at step 2
    Case k = MakeCase(policy, 3, 3, /*copy_prior=*/false, norm);
    torch::NoGradGuard no_grad;
    const Rollout roll = Roll(k, 3, 1.0);
    for (int64_t t = 0; t < 3; ++t) {
      const std::string what =
          std::string(norm) + (policy ? " +z step " : " step ") + std::to_string(t);
      const torch::Tensor tokens = roll.frames.slice(1, 0, t + 1);
      const torch::Tensor actions = k.actions.slice(0, 0, t + 1).transpose(0, 1);  // [B, t+1, D]
      const torch::Tensor z = policy ? k.m->DynamicsZ(tokens, actions) : torch::Tensor();
      EXPECT_TRUE(torch::equal(DecodeNextFrame(k.m, tokens, actions, z, 1, 1.0, Seeds(t, 3)),
                               roll.frames.select(1, t + 1)))
          << what;
      const torch::Tensor ext = roll.frames.slice(1, 0, t + 2);
      const torch::Tensor ext_actions = torch::cat({actions, torch::zeros({3, 1, 7})}, 1);
      const DynamicsOutput full =
          k.m->Dynamics(ext, ext_actions, policy ? k.m->DynamicsZ(ext, ext_actions) : z);
      ExpectClose(roll.reward.select(1, t), full.reward.select(1, t + 1), what + " reward");
      ExpectClose(roll.terminal.select(1, t), full.terminal_logit.select(1, t + 1),
                  what + " terminal");
    }
  }
}

void ExpectRollingIsTheBandedForward(Case k) {
  torch::NoGradGuard no_grad;
  const int64_t C = k.m->config.model.context_frames;
  const Rollout roll = Roll(k, 7, 1.0);
  const torch::Tensor actions = k.actions.transpose(0, 1);  // [B, 7, D]
  // z_j as the rolling path infers it: the prior over the window ending at frame j.
  std::vector<torch::Tensor> zs;
  for (int64_t j = 0; j < 7; ++j) {
    const int64_t from = std::max<int64_t>(0, j - (C - 2));
    const torch::Tensor z =
        k.m->DynamicsZ(roll.frames.slice(1, from, j + 1), actions.slice(1, from, j + 1));
    zs.push_back(z.select(1, z.size(1) - 1));
  }
  const DynamicsOutput full = k.m->dynamics->forward(roll.frames.slice(1, 0, 7), actions,
                                                     torch::stack(zs, 1), {.span = C - 1});
  ExpectClose(torch::log_softmax(full.logits, -1), roll.log_probs, "log-probabilities");
  // The window path's differ once the window has slid (frame C - 1 on): kept keys differ.
  const torch::Tensor window = k.m->NextFrameLogits(
      roll.frames.slice(1, 7 - (C - 1), 7), actions.slice(1, 7 - (C - 1), 7),
      k.m->DynamicsZ(roll.frames.slice(1, 7 - (C - 1), 7), actions.slice(1, 7 - (C - 1), 7)));
  EXPECT_GT(
      (torch::log_softmax(window, -1) - roll.log_probs.select(1, 6)).abs().max().item<double>(),
      1e-3);
}

TEST(RollingWindow, AfterTheSlideItsFramesAreTheBandedForwardOverTheHistory) {
  for (const char* norm : {"none", "identity"}) {
    SCOPED_TRACE(norm);
    ExpectRollingIsTheBandedForward(MakeCase(true, 2, 7, /*copy_prior=*/true, norm));
  }
}

TEST(RollingWindow, ARowsRolloutDoesNotDependOnTheRestOfItsBatch) {
  Case k = MakeCase(true, 3, 6);
  torch::NoGradGuard no_grad;
  const Rollout all = Roll(k, 6, 1.0);
  // Row 2 alone, seeded as in the batch.
  RollingWindow alone(k.m, k.first.slice(0, 2, 3));
  for (int64_t t = 0; t < 6; ++t) {
    DynamicsOutput r;
    const torch::Tensor frame = alone.Step(torch::tensor({int64_t{0}}), k.actions[t].slice(0, 2, 3),
                                           1.0, {Seeds(t, 3)[2]}, r);
    EXPECT_TRUE(torch::equal(frame, all.frames.select(1, t + 1).slice(0, 2, 3))) << "step " << t;
    ExpectClose(r.reward, all.reward.select(1, t).slice(0, 2, 3), "reward " + std::to_string(t));
  }
}

TEST(RollingWindow, AnEndedEpisodeLeavesTheRestAsTheyWereAndCannotComeBack) {
  Case k = MakeCase(false, 3, 6);
  torch::NoGradGuard no_grad;
  const Rollout all = Roll(k, 6, 1.0);
  RollingWindow rolling(k.m, k.first);
  const torch::Tensor kept = torch::tensor({int64_t{0}, int64_t{2}});
  for (int64_t t = 0; t < 6; ++t) {
    DynamicsOutput r;
    const bool everyone = t < 2;  // row 1 ends after step 1
    const torch::Tensor rows = everyone ? torch::arange(3) : kept;
    std::vector<uint64_t> seeds = Seeds(t, 3);
    if (!everyone) seeds = {seeds[0], seeds[2]};
    const torch::Tensor frame =
        rolling.Step(rows, k.actions[t].index_select(0, rows), 1.0, seeds, r);
    EXPECT_TRUE(torch::equal(frame, all.frames.select(1, t + 1).index_select(0, rows)))
        << "step " << t;
  }
  DynamicsOutput r;
  EXPECT_THROW(rolling.Step(torch::arange(3), k.actions[0], 1.0, Seeds(0, 3), r), Error);
}

TEST(RollingWindow, NeedsRotaryTime) {
  DynamicsConfig c = test::TinyConfig(false);
  c.model.objective = "next_frame";
  WorldModel m(c);
  EXPECT_THROW(RollingWindow(m, torch::zeros({1, 6}, torch::kInt64)), Error);
}

}  // namespace
}  // namespace wm::train

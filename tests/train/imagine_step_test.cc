// The cached imagination step (train/imagine_step.h) against the full-window recomputation it
// replaces: equal up to float rounding (a tolerance of 1e-5 on log-probabilities, rewards and
// transformer outputs of unit scale), the same sampled tokens, and a row's step independent of
// the rest of its batch.
#include "train/imagine_step.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "tests/train/test_config.h"
#include "train/batch.h"
#include "train/world_model.h"

namespace wm::train {
namespace {

constexpr double kTolerance = 1e-5;  // float rounding of other GEMM shapes, not a real change

void ExpectClose(const torch::Tensor& a, const torch::Tensor& b, const std::string& what) {
  ASSERT_EQ(a.sizes(), b.sizes()) << what;
  EXPECT_LT((a - b).abs().max().item<double>(), kTolerance) << what;
}

// A random model and window: Tc = 3 frames of 3 rows.
struct Case {
  WorldModel m{nullptr};
  torch::Tensor tokens, actions, z;  // [B, Tc, ...]
  torch::Tensor next;                // [B, N]: a frame to extend the window with
};

Case MakeCase(const std::string& objective, bool policy, uint64_t seed) {
  DynamicsConfig c = test::TinyConfig(policy);
  c.model.objective = objective;
  c.model.copy_prior = true;
  torch::manual_seed(seed);
  Case k{WorldModel(c)};
  k.m->eval();
  const int64_t N = int64_t{c.model.grid_h} * c.model.grid_w;
  k.tokens = torch::randint(c.model.num_codes, {3, 3, N}, torch::kInt64);
  k.actions = torch::randn({3, 3, 7});
  k.next = torch::randint(c.model.num_codes, {3, N}, torch::kInt64);
  torch::NoGradGuard no_grad;
  k.z = k.m->DynamicsZ(k.tokens, k.actions);
  return k;
}

torch::Tensor Extend(const torch::Tensor& x, const torch::Tensor& frame) {
  return torch::cat({x, frame.unsqueeze(1)}, 1);
}

TEST(TemporalCache, AppendedFrameMatchesTheWholeWindow) {
  torch::manual_seed(1);
  StTransformer t(StBlockOptions{.dim = 32, .heads = 4, .mlp_ratio = 2}, 2);
  torch::NoGradGuard no_grad;
  const torch::Tensor x = torch::randn({2, 4, 6, 32});  // [B, T+1, N, D]
  const torch::Tensor whole = t->forward(x);
  TemporalCache cache;
  const torch::Tensor window = t->ForwardCaching(x.slice(1, 0, 3), cache);
  EXPECT_TRUE(torch::equal(window, t->forward(x.slice(1, 0, 3))));  // same computation
  ExpectClose(window, whole.slice(1, 0, 3), "causal: the window ignores the frame after it");
  ExpectClose(t->ForwardAppended(x.slice(1, 3, 4), cache), whole.slice(1, 3, 4), "new frame");
  ASSERT_EQ(cache.keys.size(), 2u);
  EXPECT_EQ(cache.keys[0].sizes(), (std::vector<int64_t>{2 * 6, 4, 3, 8}));  // [B*N, H, T, hd]
}

TEST(CachedWindow, LogProbsAndRewardEqualTheFullWindow) {
  for (const char* objective : {"masked", "next_frame"})
    for (bool policy : {true, false}) {
      const std::string what = std::string(objective) + (policy ? " +z" : "");
      Case k = MakeCase(objective, policy, 5);
      torch::NoGradGuard no_grad;
      CachedWindow window(k.m, k.tokens, k.actions, k.z);
      // A partial frame (half masked) for the MaskGIT rounds; next_frame ignores it.
      const int64_t K = k.m->config.model.num_codes;
      torch::Tensor partial = k.next.clone();
      partial.slice(1, 0, 3).fill_(K);
      ExpectClose(window.LogProbs(partial),
                  torch::log_softmax(k.m->NextFrameLogits(k.tokens, k.actions, k.z, partial), -1),
                  what + " log-probabilities");
      // The reward of the step to `next`, from the window extended by it (a zero action after it).
      const torch::Tensor tokens = Extend(k.tokens, k.next);
      const torch::Tensor actions = Extend(k.actions, torch::zeros({3, 7}));
      const torch::Tensor z = policy ? k.m->DynamicsZ(tokens, actions) : torch::Tensor();
      const DynamicsOutput full = k.m->Dynamics(tokens, actions, z);
      const DynamicsOutput step = window.StepReward(tokens, actions, z);
      ExpectClose(step.reward, full.reward.select(1, 3), what + " reward");
      ExpectClose(step.terminal_logit, full.terminal_logit.select(1, 3), what + " terminal");
    }
}

TEST(CachedWindow, DecodesTheFramesOfDecodeNextFrame) {
  for (const char* objective : {"masked", "next_frame"}) {
    Case k = MakeCase(objective, true, 9);
    CachedWindow window(k.m, k.tokens, k.actions, k.z);
    for (double temperature : {0.0, 1.0}) {
      const std::vector<uint64_t> seeds = {11, 12, 13};
      EXPECT_TRUE(
          torch::equal(window.DecodeNext(4, temperature, seeds),
                       DecodeNextFrame(k.m, k.tokens, k.actions, k.z, 4, temperature, seeds)))
          << objective << " at temperature " << temperature;
    }
  }
}

TEST(CachedWindow, ARowsStepDoesNotDependOnTheRestOfItsBatch) {
  Case k = MakeCase("next_frame", true, 13);
  CachedWindow batch(k.m, k.tokens, k.actions, k.z);
  const torch::Tensor frames = batch.DecodeNext(1, 1.0, {21, 22, 23});
  const torch::Tensor logp = batch.LogProbs({});
  for (int64_t b = 0; b < 3; ++b) {
    auto row = [b](const torch::Tensor& x) { return x.slice(0, b, b + 1); };
    CachedWindow alone(k.m, row(k.tokens), row(k.actions), row(k.z));
    EXPECT_TRUE(
        torch::equal(alone.DecodeNext(1, 1.0, {21 + static_cast<uint64_t>(b)}), row(frames)))
        << "row " << b;
    ExpectClose(alone.LogProbs({}), row(logp), "row " + std::to_string(b));
  }
}

}  // namespace
}  // namespace wm::train

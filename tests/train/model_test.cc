// The dynamics model on in-memory tensors: causality (exact), the ELBO terms on hand-computed
// cases, straight-through sampling, training masks, MaskGIT decoding, and overfitting a batch.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <tuple>

#include "tests/train/test_config.h"
#include "train/batch.h"
#include "train/world_model.h"
#include "trainkit/adamw.h"

namespace wm::train {
namespace {

struct Inputs {
  torch::Tensor tokens, actions;
};

Inputs RandomInputs(const DynamicsConfig& c, int64_t B, uint64_t seed) {
  torch::manual_seed(seed);
  const int64_t T = c.model.context_frames, N = c.model.tokens_per_frame();
  return {torch::randint(c.model.num_codes, {B, T, N}, torch::kInt64), torch::randn({B, T, 7})};
}

// Everything the dynamics model outputs for a (masked) sequence, z from the prior.
DynamicsOutput RunModel(WorldModel& m, const torch::Tensor& tokens, const torch::Tensor& actions) {
  torch::NoGradGuard no_grad;
  return m->Dynamics(tokens, actions, m->DynamicsZ(tokens, actions));
}

void ExpectPrefixEqual(const torch::Tensor& a, const torch::Tensor& b, int64_t frames,
                       const char* what) {
  EXPECT_TRUE(torch::equal(a.slice(1, 0, frames), b.slice(1, 0, frames))) << what;
  EXPECT_FALSE(torch::equal(a, b)) << what << " did not change at all";
}

// With "next_frame" position j predicts frame j+1, so this also checks that it cannot see it.
TEST(DynamicsCausality, FutureFrameDoesNotChangeEarlierPredictions) {
  for (bool policy : {true, false})
    for (const char* objective : {"masked", "next_frame"}) {
      DynamicsConfig c = test::TinyConfig(policy);
      c.model.objective = objective;
      c.model.copy_prior = c.model.objective == "next_frame";
      torch::manual_seed(1);
      WorldModel m(c);
      Inputs in = RandomInputs(c, 2, 2);
      for (int64_t j = 1; j < c.model.context_frames; ++j) {
        torch::Tensor changed = in.tokens.clone();
        changed.select(1, j).random_(c.model.num_codes);
        DynamicsOutput a = RunModel(m, in.tokens, in.actions), b = RunModel(m, changed, in.actions);
        ExpectPrefixEqual(a.logits, b.logits, j, "logits");
        ExpectPrefixEqual(a.reward, b.reward, j, "reward");
        ExpectPrefixEqual(a.terminal_logit, b.terminal_logit, j, "terminal");
        if (policy) {
          torch::NoGradGuard no_grad;
          ExpectPrefixEqual(m->policy->Prior(in.tokens, in.actions),
                            m->policy->Prior(changed, in.actions), j, "prior");
        }
      }
    }
}

TEST(DynamicsCausality, FutureActionDoesNotChangePredictionsUpToItsFrame) {
  DynamicsConfig c = test::TinyConfig(true);
  torch::manual_seed(3);
  WorldModel m(c);
  Inputs in = RandomInputs(c, 2, 4);
  // a_j leads to frame j+1: frames 0..j must not see it.
  for (int64_t j = 0; j + 1 < c.model.context_frames; ++j) {
    torch::Tensor changed = in.actions.clone();
    changed.select(1, j).add_(1.5);
    DynamicsOutput a = RunModel(m, in.tokens, in.actions), b = RunModel(m, in.tokens, changed);
    ExpectPrefixEqual(a.logits, b.logits, j + 1, "logits");
    ExpectPrefixEqual(a.reward, b.reward, j + 1, "reward");
  }
}

TEST(DynamicsCausality, PolicyDecoderDoesNotSeeItsOwnAction) {
  DynamicsConfig c = test::TinyConfig(true);
  torch::manual_seed(5);
  WorldModel m(c);
  Inputs in = RandomInputs(c, 2, 6);
  torch::NoGradGuard no_grad;
  torch::Tensor z = torch::softmax(torch::randn({2, 4, 4}), -1).view({2, 16});
  // Decoder output at h given a fixed z must not depend on a_h (only a_{<h}).
  auto decode = [&](const torch::Tensor& actions) {
    auto& p = *m->policy;
    const int64_t T = actions.size(1);
    torch::Tensor prev = torch::cat({p.decoder_start.expand({2, 1, -1}),
                                     p.decoder_prev_action->forward(actions.slice(1, 0, T - 1))},
                                    1);
    torch::Tensor extra = prev + p.decoder_z->forward(z).unsqueeze(1);
    return p.decoder_head->forward(p.decoder->forward(p.Embed(in.tokens, extra)).mean(2));
  };
  torch::Tensor changed = in.actions.clone();
  changed.select(1, 2).add_(1.0);
  ExpectPrefixEqual(decode(in.actions), decode(changed), 3, "policy decoder");
}

TEST(PolicyLosses, CategoricalKlMatchesHandComputation) {
  torch::Tensor q = torch::zeros({1, 2});  // q = [0.5, 0.5]
  torch::Tensor p = torch::log(torch::tensor({0.25f, 0.75f})).view({1, 2});
  const double expected = 0.5 * std::log(2.0) + 0.5 * std::log(2.0 / 3.0);
  EXPECT_NEAR(CategoricalKl(q, p).item<double>(), expected, 1e-6);
  EXPECT_NEAR(CategoricalKl(q, q).item<double>(), 0.0, 1e-7);
  // Sums over categories: two identical categories -> twice the value.
  EXPECT_NEAR(CategoricalKl(q.repeat({2, 1}), p.repeat({2, 1})).item<double>(), 2 * expected, 1e-6);
}

TEST(PolicyLosses, GaussianNllMatchesHandComputation) {
  const double c = 0.5 * std::log(2 * std::numbers::pi);
  EXPECT_NEAR(GaussianNll(torch::ones({1}), torch::zeros({1}), torch::zeros({1})).item<double>(),
              0.5 + c, 1e-6);
  const double ls = std::log(2.0);
  EXPECT_NEAR(
      GaussianNll(torch::full({1}, 2.0), torch::ones({1}), torch::full({1}, ls)).item<double>(),
      0.5 * 0.25 + ls + c, 1e-6);
}

TEST(PolicyLosses, ElboSumsOverStepsAndWeightsKlByBeta) {
  DynamicsConfig c = test::TinyConfig(true);
  c.policy.categories = 1;
  c.policy.classes = 2;
  c.policy.kl_beta = 0.5;
  PolicyEmbedding pe(c.model, c.policy);
  PolicyOutput out;
  out.posterior_logits = torch::zeros({1, 1, 2});         // q = [0.5, 0.5]
  out.prior_logits = torch::stack({torch::zeros({1, 2}),  // p_0 = q
                                   torch::log(torch::tensor({0.25f, 0.75f})).view({1, 2})})
                         .unsqueeze(0);  // [1, 2, 1, 2]
  out.action_mean = torch::zeros({1, 2, 7});
  out.action_log_std = torch::zeros({1, 2, 7});
  torch::Tensor actions = torch::zeros({1, 2, 7});
  actions[0][1][0] = 1.0;
  PolicyLosses l = pe->Losses(out, actions);
  const double c0 = 0.5 * std::log(2 * std::numbers::pi);
  const double nll = 14 * c0 + 0.5;  // 2 steps x 7 dims, one residual of 1
  const double kl = 0.5 * std::log(2.0) + 0.5 * std::log(2.0 / 3.0);
  EXPECT_NEAR(l.nll.item<double>(), nll, 1e-5);
  EXPECT_NEAR(l.kl.item<double>(), kl, 1e-6);
  EXPECT_NEAR(l.loss.item<double>(), nll + 0.5 * kl, 1e-5);
}

// A mixture of widths pads the narrower dataset's actions and masks them (Octo): whatever the
// padding holds changes no loss and no gradient, while a real value does.
TEST(ActionMask, PaddingChangesNoLossOrGradient) {
  DynamicsConfig c = test::TinyConfig(true);
  c.model.action_dim = 14;
  torch::manual_seed(3);
  WorldModel m(c);
  const int64_t B = 2, T = c.model.context_frames, N = int64_t{c.model.grid_h} * c.model.grid_w;
  SegmentBatch b;
  b.tokens = torch::randint(c.model.num_codes, {B, T, N}, torch::kInt64);
  b.actions = torch::randn({B, T, 14});
  b.rewards = torch::rand({B, T});
  b.terminals = torch::zeros({B, T});
  b.mask = TrainingMask(torch::rand({B, T}), torch::rand({B, T, N}), torch::rand({B, T}), 0.7);
  b.z_noise = torch::rand({B, c.policy.categories, c.policy.classes});
  b.action_mask = torch::ones({B, 1, 14});
  b.action_mask[1].slice(-1, 7).fill_(0);  // row 1: a 7-dim dataset's, padded to 14
  auto losses_and_grads = [&](const SegmentBatch& batch) {
    m->zero_grad();
    WorldModelLosses l = m->Losses(batch);
    l.total.backward();
    std::vector<torch::Tensor> out = {l.total.detach(), l.policy->nll.detach()};
    for (const auto& p : m->parameters()) out.push_back(p.grad().clone());
    return out;
  };
  const auto base = losses_and_grads(b);
  SegmentBatch noisy = b;
  noisy.actions = b.actions.clone();
  noisy.actions[1].slice(-1, 7).copy_(torch::randn({T, 7}) * 100);
  const auto with_noise = losses_and_grads(noisy);
  ASSERT_EQ(base.size(), with_noise.size());
  for (size_t i = 0; i < base.size(); ++i) EXPECT_TRUE(torch::equal(base[i], with_noise[i])) << i;
  SegmentBatch real = b;
  real.actions = b.actions.clone();
  real.actions[1][0][3] += 1;  // a real value of the same row
  EXPECT_FALSE(torch::equal(losses_and_grads(real)[1], base[1]));
}

TEST(StraightThrough, ForwardIsOneHotAndGradientIsSoftmaxGradient) {
  torch::manual_seed(7);
  torch::Tensor logits = torch::randn({3, 5}, torch::requires_grad());
  torch::Tensor u = torch::rand({3, 5});
  torch::Tensor s = StraightThroughSample(logits, u);
  EXPECT_TRUE(torch::equal(s.sum(-1), torch::ones({3})));
  EXPECT_TRUE(torch::equal((s == 1).sum(-1), torch::ones({3}, torch::kLong)));
  // The chosen class is argmax(logits + Gumbel(u)).
  EXPECT_TRUE(torch::equal(s.argmax(-1), (logits - torch::log(-torch::log(u))).argmax(-1)));
  torch::Tensor w = torch::randn({3, 5});
  (s * w).sum().backward();
  torch::Tensor g = logits.grad().clone();
  logits.mutable_grad().zero_();
  (torch::softmax(logits, -1) * w).sum().backward();
  EXPECT_TRUE(torch::allclose(g, logits.grad(), 1e-6, 1e-7));
}

TEST(StraightThrough, SampleFrequenciesFollowTheSoftmax) {
  torch::manual_seed(8);
  torch::Tensor logits = torch::log(torch::tensor({0.1f, 0.2f, 0.7f})).expand({20000, 3});
  torch::Tensor counts = StraightThroughSample(logits, torch::rand({20000, 3})).detach().mean(0);
  EXPECT_TRUE(torch::allclose(counts, torch::tensor({0.1f, 0.2f, 0.7f}), 0, 0.015)) << counts;
}

TEST(TrainingMask, FirstFrameCleanCountsFollowTheRatio) {
  torch::manual_seed(9);
  torch::Tensor u_ratio = torch::tensor({{0.3f, 0.0f, 0.5f, 0.999f}});
  torch::Tensor mask = TrainingMask(u_ratio, torch::rand({1, 4, 10}), torch::zeros({1, 4}), 1.0);
  torch::Tensor counts = mask.sum(-1).view({4});
  EXPECT_EQ(counts[0].item<int64_t>(), 0);
  EXPECT_EQ(counts[1].item<int64_t>(), 10);  // cos(0) = 1: all masked
  EXPECT_EQ(counts[2].item<int64_t>(),
            static_cast<int64_t>(std::ceil(10 * std::cos(0.25 * std::numbers::pi))));
  EXPECT_EQ(counts[3].item<int64_t>(), 1);  // at least one
  // Frames drawn as context (u_frame >= frame_prob) stay clean; with none drawn, the last is
  // the target.
  torch::Tensor some =
      TrainingMask(u_ratio, torch::rand({1, 4, 10}), torch::tensor({{0.f, 0.9f, 0.2f, 0.9f}}), 0.5);
  EXPECT_EQ(some.sum(-1).view({4})[1].item<int64_t>(), 0);
  EXPECT_EQ(some.sum(-1).view({4})[2].item<int64_t>(), counts[2].item<int64_t>());
  torch::Tensor none = TrainingMask(u_ratio, torch::rand({1, 4, 10}), torch::ones({1, 4}), 0.5);
  EXPECT_EQ(none.sum(-1).view({4})[3].item<int64_t>(), 1);
  EXPECT_EQ(none.sum().item<int64_t>(), 1);
}

// A model from `model_seed` and a 2-row, 3-frame context (tokens, actions, prior z) to decode.
struct DecodeCase {
  WorldModel m{nullptr};
  torch::Tensor ctx, act, z;
};
DecodeCase MakeDecodeCase(const DynamicsConfig& c, uint64_t model_seed) {
  torch::manual_seed(model_seed);
  DecodeCase d{WorldModel(c)};
  Inputs in = RandomInputs(c, 2, model_seed + 1);
  d.ctx = in.tokens.slice(1, 0, 3);
  d.act = in.actions.slice(1, 0, 3);
  d.z = d.m->DynamicsZ(d.ctx, d.act);
  return d;
}

TEST(MaskGit, DecodingIsDeterministicGivenSeedAndFillsEveryToken) {
  DynamicsConfig c = test::TinyConfig(true);
  auto [m, ctx, act, z] = MakeDecodeCase(c, 10);
  torch::Tensor a = DecodeNextFrame(m, ctx, act, z, 4, 1.0, {123, 124});
  torch::Tensor b = DecodeNextFrame(m, ctx, act, z, 4, 1.0, {123, 124});
  EXPECT_TRUE(torch::equal(a, b));
  EXPECT_EQ(a.sizes(), (std::vector<int64_t>{2, 6}));
  // A row's frame depends on its own seed and context only, not on the rest of the batch.
  torch::Tensor row1 =
      DecodeNextFrame(m, ctx.slice(0, 1, 2), act.slice(0, 1, 2), z.slice(0, 1, 2), 4, 1.0, {124});
  EXPECT_TRUE(torch::equal(row1[0], a[1]));
  EXPECT_FALSE(torch::equal(DecodeNextFrame(m, ctx, act, z, 4, 1.0, {123, 999}), a));
  EXPECT_TRUE((a >= 0).all().item<bool>() && (a < c.model.num_codes).all().item<bool>());
  torch::Tensor g1 = DecodeNextFrame(m, ctx, act, z, 1, 0.0, {1, 2});
  torch::Tensor g2 = DecodeNextFrame(m, ctx, act, z, 1, 0.0, {3, 4});
  EXPECT_TRUE(torch::equal(g1, g2));  // argmax ignores the seed
  torch::NoGradGuard no_grad;
  torch::Tensor seq = torch::cat({ctx, torch::full({2, 1, 6}, c.model.num_codes)}, 1);
  torch::Tensor one_shot = m->Dynamics(seq, torch::cat({act, torch::zeros({2, 1, 7})}, 1),
                                       torch::cat({z, torch::zeros({2, 1, 16})}, 1))
                               .logits.select(1, 3)
                               .argmax(-1);
  EXPECT_TRUE(torch::equal(g1, one_shot));  // one greedy step = argmax of the fully masked frame
}

// wm-eval --retrace-ks' token_entropy: each token's entropy in the round that fixed it. Hand
// case, N = 2, K = 4: round 0 gives token 0 a sure code and token 1 a uniform distribution
// (ln 4); round 1 gives token 1 two equally likely codes (ln 2). Two rounds fix one token each
// (cos(pi/4) * 2 floors to 1 kept masked), the sure one first.
TEST(MaskGit, TokenEntropyIsTheOneOfTheRoundThatFixedTheToken) {
  const float inf = std::numeric_limits<float>::infinity();
  EXPECT_NEAR(Entropy(torch::log(torch::tensor({0.25f, 0.25f, 0.25f, 0.25f}))).item<float>(),
              std::log(4.f), 1e-6);
  EXPECT_EQ(Entropy(torch::tensor({0.f, -inf, -inf})).item<float>(), 0.f);
  int round = 0;
  auto log_probs = [&](const torch::Tensor&) {
    const float l2 = std::log(0.5f), l4 = std::log(0.25f);
    auto rows = round++ == 0 ? torch::tensor({0.f, -inf, -inf, -inf, l4, l4, l4, l4})
                             : torch::tensor({0.f, -inf, -inf, -inf, l2, l2, -inf, -inf});
    return rows.view({1, 2, 4});
  };
  torch::Tensor entropy;
  torch::Tensor frame = SampleFrame(log_probs, 2, 4, false, 2, 1.0, {7}, &entropy);
  EXPECT_EQ(frame[0][0].item<int64_t>(), 0);
  EXPECT_LT(frame[0][1].item<int64_t>(), 2);  // fixed in round 1
  EXPECT_EQ(entropy.sizes(), (std::vector<int64_t>{1, 2}));
  EXPECT_EQ(entropy[0][0].item<float>(), 0.f);
  EXPECT_NEAR(entropy[0][1].item<float>(), std::log(2.f), 1e-6);
  // Asking for the entropy does not change the frame sampled.
  round = 0;
  EXPECT_TRUE(torch::equal(frame, SampleFrame(log_probs, 2, 4, false, 2, 1.0, {7})));
  round = 0;  // one pass: the first call's entropies
  SampleFrame(log_probs, 2, 4, true, 2, 1.0, {7}, &entropy);
  EXPECT_NEAR(entropy[0][1].item<float>(), std::log(4.f), 1e-6);
}

// model.copy_prior starts at the copy rule on any grid, either objective and every level of a
// residual tokenizer's cells; without it an untrained model's argmax is unrelated to the last
// frame.
TEST(CopyPrior, UntrainedModelPredictsTheLastFrame) {
  for (const char* objective : {"masked", "next_frame"})
    for (auto [gh, gw, levels] : {std::tuple{2, 3, 1}, std::tuple{5, 4, 1}, std::tuple{2, 3, 3}})
      for (bool copy_prior : {true, false}) {
        DynamicsConfig c = test::TinyConfig(true);
        c.model.objective = objective;
        c.model.grid_h = gh;
        c.model.grid_w = gw;
        c.model.levels = levels;
        c.model.num_codes = 64;
        c.model.tied_token_head = true;
        c.model.copy_prior = copy_prior;
        torch::manual_seed(20);
        WorldModel m(c);
        Inputs in = RandomInputs(c, 3, 21);
        torch::Tensor ctx = in.tokens.slice(1, 0, 3), act = in.actions.slice(1, 0, 3);
        torch::NoGradGuard no_grad;
        torch::Tensor logp =
            torch::log_softmax(m->NextFrameLogits(ctx, act, m->DynamicsZ(ctx, act)), -1);
        torch::Tensor last = ctx.select(1, 2);  // [B, N]
        const double copied = (logp.argmax(-1) == last).to(torch::kDouble).mean().item<double>();
        const double p_copy = logp.gather(-1, last.unsqueeze(-1)).exp().mean().item<double>();
        if (copy_prior) {
          EXPECT_EQ(copied, 1.0) << objective << " " << gh << "x" << gw << " x" << levels;
          EXPECT_GT(p_copy, 0.4) << objective;  // ~ K / (K + K - 1): bias log(K) over ~0 logits
          EXPECT_LT(p_copy, 0.6) << objective;
        } else {
          // The tied head scores codes with the input's embedding rows, which the residual stream
          // carries: an untrained next-frame model over three levels leans to its input's codes
          // (0.44 of them at this seed), far from the copy rule still.
          EXPECT_LT(copied, levels == 1 ? 0.3 : 0.6) << objective << " x" << levels;
        }
      }
}

// A residual tokenizer's codes per cell: the cell's input is the sum of its levels' embeddings,
// so a code of any level reaches the later predictions (not the earlier: causal time); the policy
// embedding reads the first level only.
TEST(Levels, EveryLevelReachesTheModelAndThePolicyReadsTheFirst) {
  DynamicsConfig c = test::TinyConfig(true);
  c.model.levels = 3;
  const int64_t K = c.model.num_codes, cells = c.model.cells();
  torch::manual_seed(30);
  WorldModel m(c);
  Inputs in = RandomInputs(c, 2, 31);  // tokens [2, T, 3 x cells], level-major
  auto with_code_changed = [&](int64_t level, int64_t cell) {
    torch::Tensor t = in.tokens.clone();
    t.select(1, 1).select(1, level * cells + cell).add_(1).remainder_(K);  // in frame 1
    return t;
  };
  const torch::Tensor fine = with_code_changed(2, 4), coarse = with_code_changed(0, 4);
  ExpectPrefixEqual(RunModel(m, in.tokens, in.actions).logits, RunModel(m, fine, in.actions).logits,
                    1, "a level-2 code");
  torch::NoGradGuard no_grad;
  const torch::Tensor z = m->DynamicsZ(in.tokens, in.actions);
  EXPECT_TRUE(torch::equal(z, m->DynamicsZ(fine, in.actions)));
  EXPECT_FALSE(torch::equal(z, m->DynamicsZ(coarse, in.actions)));
  EXPECT_EQ(RunModel(m, in.tokens, in.actions).logits.sizes(),
            (std::vector<int64_t>{2, c.model.context_frames, 3 * cells, K}));
}

TEST(NextFrame, DecodingIsOnePassOverTheContext) {
  DynamicsConfig c = test::TinyConfig(true);
  c.model.objective = "next_frame";
  auto [m, ctx, act, z] = MakeDecodeCase(c, 22);
  torch::Tensor greedy = DecodeNextFrame(m, ctx, act, z, 4, 0.0, {1, 2});
  torch::NoGradGuard no_grad;
  // Position 2 (frame 2 + a_2) predicts frame 3; no appended masked frame.
  EXPECT_TRUE(torch::equal(greedy, m->Dynamics(ctx, act, z).logits.select(1, 2).argmax(-1)));
  torch::Tensor a = DecodeNextFrame(m, ctx, act, z, 4, 1.0, {5, 6});
  EXPECT_TRUE(torch::equal(a, DecodeNextFrame(m, ctx, act, z, 1, 1.0, {5, 6})));  // steps unused
  EXPECT_FALSE(torch::equal(a, DecodeNextFrame(m, ctx, act, z, 4, 1.0, {7, 8})));
  // The last action matters: it is the input of the predicting position.
  torch::Tensor moved = act.clone();
  moved.select(1, 2).mul_(-3);
  EXPECT_FALSE(torch::equal(m->NextFrameLogits(ctx, act, z), m->NextFrameLogits(ctx, moved, z)));
}

class Overfit : public ::testing::TestWithParam<int> {};

// One level, and three (a residual tokenizer's codes: every level is a target).
TEST_P(Overfit, TinyBatchReachesNearZeroLoss) {
  DynamicsConfig c = test::TinyConfig(true);
  c.model.levels = GetParam();
  torch::manual_seed(12);
  WorldModel m(c);
  Inputs in = RandomInputs(c, 2, 13);
  SegmentBatch b;
  b.tokens = in.tokens;
  b.actions = in.actions;
  b.rewards = torch::tensor({{0.f, 1.f, 0.f, 0.5f}, {1.f, 0.f, 0.f, 0.f}});
  b.terminals = torch::tensor({{0.f, 0.f, 1.f, 0.f}, {0.f, 1.f, 0.f, 0.f}});
  b.mask = torch::ones({2, 4, c.model.tokens_per_frame()}, torch::kBool);
  b.mask.select(1, 0).fill_(false);
  b.z_noise = torch::rand({2, 4, 4});
  std::vector<std::pair<std::string, torch::Tensor>> named;
  for (const auto& p : m->named_parameters()) named.emplace_back(p.key(), p.value());
  trainkit::AdamW opt(named, {.lr = 3e-3, .beta1 = 0.9, .beta2 = 0.99, .weight_decay = 0});
  WorldModelLosses l;
  for (int step = 0; step < 300; ++step) {  // 8 reward targets: one per position
    opt.ZeroGrad();
    l = m->Losses(b);
    l.total.backward();
    opt.Step();
  }
  EXPECT_LT(l.token_ce.item<double>(), 0.05);
  EXPECT_EQ(l.token_accuracy, 1.0);
  EXPECT_LT(l.reward_mse.item<double>(), 1e-3);
  EXPECT_LT(l.terminal_bce.item<double>(), 0.1);
}

INSTANTIATE_TEST_SUITE_P(Levels, Overfit, ::testing::Values(1, 3));

}  // namespace
}  // namespace wm::train

// The training loop on small token datasets: loss goes down, runs are byte-for-byte
// reproducible, resume equals an uninterrupted run, errors name file and key, and the public
// model API loads the result.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/sha256.h"
#include "core/tokens/token_dataset.h"
#include "tests/core/test_util.h"
#include "tests/train/moving_block.h"
#include "tests/train/test_config.h"
#include "train/dynamics_model.h"
#include "train/launch.h"
#include "train/segment_sampler.h"
#include "train/trainer.h"

namespace wm::train {
namespace {
namespace fs = std::filesystem;

DynamicsConfig TrainConfigForTest() {
  DynamicsConfig c = test::TinyConfig(true);
  c.model.grid_h = c.model.grid_w = 4;
  c.model.num_codes = 32;
  c.train.batch_size = 4;
  c.train.steps = 20;
  c.train.max_lr = 3e-3;
  c.train.min_lr = 3e-4;
  c.train.warmup_steps = 3;
  c.train.checkpoint_every = 10;
  c.train.log_every = 5;
  c.train.val_every = 10;
  c.train.val_batches = 1;
  c.train.seed = 11;
  return c;
}

class DynamicsTrainTest : public ::testing::Test {
 protected:
  void SetUp() override {
    test::WriteMovingBlockTokens(dir_ / "tokens", {.episodes = 8, .steps = 10, .seed = 1});
    test::WriteMovingBlockTokens(dir_ / "val", {.episodes = 3, .steps = 10, .seed = 2});
  }
  TrainOptions Options(const std::string& run, int64_t steps) const {
    TrainOptions o{
        .config = TrainConfigForTest(), .token_dirs = {dir_ / "tokens"}, .out_dir = dir_ / run};
    o.config.train.steps = steps;
    o.show_progress = false;
    return o;
  }
  std::string Hash(const std::string& run, const std::string& file) const {
    return Sha256Hex(ReadFile(dir_ / (run + "/" + file)));
  }
  wm::test::TempDir dir_;
};

TEST_F(DynamicsTrainTest, LossDecreasesAndMetricsAreWritten) {
  TrainOptions o = Options("run", 60);
  o.val_dir = dir_ / "val";
  o.config.train.val_every = 30;
  TrainSummary s = TrainDynamics(o);
  EXPECT_EQ(s.end_step, 60);
  EXPECT_LT(s.last_loss, 0.7 * s.first_loss) << "first " << s.first_loss;
  EXPECT_GE(s.last_val_token_accuracy, 0.0);
  EXPECT_GT(s.tokens_per_second, 0.0);
  const std::string csv = ReadFile(dir_ / "run/metrics.csv");
  EXPECT_EQ(csv.rfind("step,loss,token_ce,token_acc,", 0), 0u);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 1 + 12);  // header + every 5 steps
  const auto manifest = nlohmann::json::parse(ReadFile(dir_ / "run/checkpoint.json"));
  EXPECT_EQ(manifest.at("step"), 60);
  EXPECT_EQ(manifest.at("data")[0].at("tokenizer_checkpoint_sha256"), "moving-block-tokenizer");
  EXPECT_EQ(manifest.at("data")[0].at("index_sha256").get<std::string>().size(), 64u);
  EXPECT_TRUE(manifest.contains("git_commit"));
  EXPECT_FALSE(manifest.at("libraries").at("libtorch").get<std::string>().empty());
  EXPECT_FALSE(manifest.at("libraries").at("blas").get<std::string>().empty());
}

TEST_F(DynamicsTrainTest, SameSeedGivesIdenticalCheckpointBytes) {
  TrainDynamics(Options("a", 10));
  TrainDynamics(Options("b", 10));
  EXPECT_EQ(Hash("a", "checkpoint.wmt"), Hash("b", "checkpoint.wmt"));
  EXPECT_EQ(Hash("a", "checkpoint.json"), Hash("b", "checkpoint.json"));
  TrainOptions other = Options("c", 10);
  other.config.train.seed = 12;
  TrainDynamics(other);
  EXPECT_NE(Hash("a", "checkpoint.wmt"), Hash("c", "checkpoint.wmt"));
}

TEST_F(DynamicsTrainTest, ResumeAfterStopEqualsUninterruptedRun) {
  TrainDynamics(Options("full", 20));
  TrainOptions first = Options("split", 20);
  first.max_steps_this_run = 10;  // as if killed after the step-10 checkpoint
  EXPECT_EQ(TrainDynamics(first).end_step, 10);
  TrainOptions rest = Options("split", 20);
  rest.resume = true;
  TrainSummary s = TrainDynamics(rest);
  EXPECT_EQ(s.start_step, 10);
  EXPECT_EQ(Hash("full", "checkpoint.wmt"), Hash("split", "checkpoint.wmt"));
  EXPECT_EQ(Hash("full", "checkpoint.json"), Hash("split", "checkpoint.json"));
}

// A kill between the archive's rename and the manifest's leaves checkpoint.json describing the
// previous checkpoint; resuming from the final archive must still end with the right manifest.
TEST_F(DynamicsTrainTest, ResumeRewritesAManifestLeftBehindByAKill) {
  TrainOptions first = Options("run", 10);
  first.max_steps_this_run = 5;
  TrainDynamics(first);
  const std::string stale = ReadFile(dir_ / "run/checkpoint.json");
  TrainOptions rest = Options("run", 10);
  rest.resume = true;
  TrainDynamics(rest);
  const std::string good = Hash("run", "checkpoint.json");
  WriteFileAtomically(dir_ / "run/checkpoint.json", stale);
  TrainDynamics(rest);
  EXPECT_EQ(Hash("run", "checkpoint.json"), good);
}

// The next-frame options together, adaptive norm included (the stable64 preset's).
TEST_F(DynamicsTrainTest, NextFrameCopyPriorAdaptiveNormRunsAreReproducibleAndResume) {
  auto options = [&](const std::string& run) {
    TrainOptions o = Options(run, 20);
    o.config.model.objective = "next_frame";
    o.config.model.copy_prior = true;
    o.config.model.tied_token_head = true;
    o.config.model.adaptive_norm = "identity";
    o.val_dir = dir_ / "val";
    return o;
  };
  TrainSummary full = TrainDynamics(options("full"));
  EXPECT_LT(full.last_loss, full.first_loss);
  TrainDynamics(options("again"));
  EXPECT_EQ(Hash("full", "checkpoint.wmt"), Hash("again", "checkpoint.wmt"));
  TrainOptions first = options("split");
  first.max_steps_this_run = 10;
  TrainDynamics(first);
  TrainOptions rest = options("split");
  rest.resume = true;
  TrainDynamics(rest);
  EXPECT_EQ(Hash("full", "checkpoint.wmt"), Hash("split", "checkpoint.wmt"));
  EXPECT_EQ(Hash("full", "checkpoint.json"), Hash("split", "checkpoint.json"));
  EXPECT_NE(Hash("full", "checkpoint.wmt"), [&] {
    TrainDynamics(Options("masked", 20));
    return Hash("masked", "checkpoint.wmt");
  }());
}

TEST_F(DynamicsTrainTest, RefusesOverwriteOtherConfigAndMismatchedData) {
  TrainDynamics(Options("run", 2));
  EXPECT_NE(wm::test::ErrorText([&] { TrainDynamics(Options("run", 2)); }).find("--resume"),
            std::string::npos);
  TrainOptions changed = Options("run", 3);
  changed.resume = true;
  EXPECT_NE(wm::test::ErrorText([&] {
              TrainDynamics(changed);
            }).find("different config (train.steps: 2 -> 3)"),
            std::string::npos);
  TrainOptions grid = Options("grid", 2);
  grid.config.model.grid_w = 5;
  EXPECT_NE(wm::test::ErrorText([&] { TrainDynamics(grid); }).find("key 'model.grid_h'"),
            std::string::npos);
  TrainOptions ddp = Options("ddp", 2);
  ddp.world_size = 3;
  EXPECT_NE(wm::test::ErrorText([&] { TrainDynamics(ddp); }).find("train.batch_size"),
            std::string::npos);
}

// A residual tokenizer's level stacks (token format version 3): the model takes the data's
// levels (recorded in the checkpoint; one-level runs keep their bytes, without the key), learns
// from every level and predicts whole stacks through the public API.
TEST_F(DynamicsTrainTest, TrainsOnResidualLevelStacks) {
  test::WriteMovingBlockTokens(dir_ / "stacked",
                               {.episodes = 8, .steps = 10, .seed = 1, .levels = 3});
  TrainOptions o = Options("stacked", 20);
  o.token_dirs = {dir_ / "stacked"};
  const TrainSummary s = TrainDynamics(o);
  EXPECT_LT(s.last_loss, s.first_loss);
  const auto meta = nlohmann::json::parse(ReadFile(dir_ / "stacked/checkpoint.json"));
  EXPECT_EQ(meta["config"]["model"]["levels"], 3);
  EXPECT_EQ(meta["tokenizer"]["levels"], 3);
  auto model = DynamicsModel::Load(dir_ / "stacked");
  EXPECT_EQ(model->tokens_per_frame(), 3 * 16);
  tokens::TokenDataset data(dir_ / "stacked");
  FrameContext ctx{.batch = 1, .frames = 3};
  ctx.tokens.resize(3 * 48);
  data.CopyTokens(0, 0, 3, ctx.tokens.data());
  ctx.actions.assign(data.actions(0), data.actions(0) + 3 * 7);
  const std::vector<int64_t> next = model->PredictNextFrame(ctx, 5, 4, 1.0);
  EXPECT_EQ(next.size(), 48u);
  EXPECT_EQ(model->ImagineStep(ctx, 5, 4, 1.0).tokens, next);
  TrainDynamics(Options("one", 2));
  EXPECT_FALSE(
      nlohmann::json::parse(ReadFile(dir_ / "one/checkpoint.json"))["config"]["model"].contains(
          "levels"));
}

TEST_F(DynamicsTrainTest, SamplerIsCounterBasedAndNormalisesActions) {
  SegmentSampler s({dir_ / "tokens"}, 4);
  auto a = s.Draw(5, 7, 6), b = s.Draw(5, 7, 6), c = s.Draw(5, 8, 6);
  ASSERT_EQ(a.size(), 6u);
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].episode, b[i].episode);
    EXPECT_EQ(a[i].start, b[i].start);
  }
  bool differs = false;
  for (size_t i = 0; i < a.size(); ++i)
    differs |= a[i].start != c[i].start || a[i].episode != c[i].episode;
  EXPECT_TRUE(differs);
  SegmentData whole, part;
  s.Fill(a, 0, 6, whole);
  s.Fill(a, 3, 3, part);  // rank 1 of 2 sees rows 3..5 of the same global batch
  EXPECT_TRUE(
      std::equal(part.tokens.begin(), part.tokens.end(), whole.tokens.begin() + 3 * 4 * 16));
  double sum = 0;
  for (size_t i = 0; i < whole.actions.size(); i += 7) sum += whole.actions[i];
  EXPECT_LT(std::abs(sum / (whole.actions.size() / 7)), 2.0);  // normalised scale
}

TEST_F(DynamicsTrainTest, MixtureWeightsTheDatasets) {
  test::WriteMovingBlockTokens(dir_ / "other", {.dataset = "other", .episodes = 4, .seed = 3});
  const std::string mixture = dir_ / "mix.yaml";
  WriteFileAtomically(mixture,
                      "datasets:\n  - {name: moving_block, weight: 3}\n"
                      "  - {name: other, weight: 1}\n");
  SegmentSampler s({dir_ / "tokens", dir_ / "other"}, 4, mixture);
  int first = 0;
  for (const SegmentRef& r : s.Draw(1, 0, 4000)) first += r.dataset == 0;
  EXPECT_NEAR(first / 4000.0, 0.75, 0.03);
  EXPECT_EQ(s.DataProvenance()[1].at("weight"), 1.0);
  WriteFileAtomically(mixture, "datasets:\n  - {name: moving_block, weight: 1}\n");
  EXPECT_NE(wm::test::ErrorText([&] {
              SegmentSampler({dir_ / "tokens", dir_ / "other"}, 4, mixture);
            }).find("mix.yaml"),
            std::string::npos);
}

// WHALE's policy embedding separates behaviours: after training, the prior's z of episodes of
// the same scripted policy ("eager" / "wander": they push right at different rates and hold the
// gripper differently) are more alike than z across the two policies, on held-out episodes
// (trained: cosine ~1.0 within vs ~0.02 across; untrained: 0.999 vs 0.996, which fails).
TEST_F(DynamicsTrainTest, PolicyEmbeddingsClusterByScriptedPolicy) {
  TrainOptions o = Options("policy", 300);
  TrainDynamics(o);
  auto model = DynamicsModel::Load(dir_ / "policy");
  test::WriteMovingBlockTokens(dir_ / "heldout", {.episodes = 12, .steps = 10, .seed = 9});
  tokens::TokenDataset data(dir_ / "heldout");
  const int64_t T = model->max_context_frames(), N = model->tokens_per_frame();
  std::vector<std::vector<float>> z;
  std::vector<std::string> policy;
  for (int64_t k = 0; k < data.num_episodes(); ++k) {
    if (data.episode(k).num_frames < T) continue;
    FrameContext ctx{.batch = 1, .frames = T};
    ctx.tokens.resize(T * N);
    data.CopyTokens(k, 0, T, ctx.tokens.data());
    ctx.actions.assign(data.actions(k), data.actions(k) + T * kActionDim);
    z.push_back(model->PolicyEmbedding(ctx));
    policy.push_back(data.episode(k).policy_id);
  }
  ASSERT_GE(z.size(), 6u);
  auto cosine = [](const std::vector<float>& a, const std::vector<float>& b) {
    double ab = 0, aa = 0, bb = 0;
    for (size_t i = 0; i < a.size(); ++i) ab += a[i] * b[i], aa += a[i] * a[i], bb += b[i] * b[i];
    return ab / std::sqrt(aa * bb);
  };
  double within = 0, across = 0;
  int nw = 0, na = 0;
  for (size_t i = 0; i < z.size(); ++i) {
    for (size_t j = i + 1; j < z.size(); ++j) {
      (policy[i] == policy[j] ? within : across) += cosine(z[i], z[j]);
      ++(policy[i] == policy[j] ? nw : na);
    }
  }
  within /= nw, across /= na;
  EXPECT_GT(within, across + 0.05) << "within " << within << ", across " << across;
}

TEST_F(DynamicsTrainTest, ModelApiPredictsFramesAndRewards) {
  TrainDynamics(Options("run", 10));
  auto model = DynamicsModel::Load(dir_ / "run");
  EXPECT_EQ(model->step(), 10);
  EXPECT_EQ(model->tokens_per_frame(), 16);
  FrameContext ctx{.batch = 2, .frames = 3};
  ctx.tokens.assign(2 * 3 * 16, 9);
  ctx.actions.assign(2 * 3 * 7, 0.01f);
  auto next = model->PredictNextFrame(ctx, 7);
  EXPECT_EQ(next.size(), 32u);
  EXPECT_EQ(next, model->PredictNextFrame(ctx, 7));
  RewardPrediction r = model->PredictRewards(ctx);
  EXPECT_EQ(r.reward.size(), 6u);  // 2 rows x 3 frames
  EXPECT_EQ(r.terminal_prob.size(), 6u);
  EXPECT_EQ(model->PolicyEmbedding(ctx).size(), 2u * 16);
  ctx.policy_z.assign(2 * 16, 1.0f / 4);
  EXPECT_EQ(model->PredictNextFrame(ctx, 7).size(), 32u);
  ctx.tokens[0] = 99;
  EXPECT_NE(wm::test::ErrorText([&] { model->PredictNextFrame(ctx); }).find("num_codes"),
            std::string::npos);
}

// ImagineStep (the window encoded once, every row in one batch) gives what PredictNextFrame and
// then PredictRewards over the extended window give for each row alone: the same tokens (same
// row seeds), rewards and terminal probabilities within float rounding (docs/reports.md).
TEST_F(DynamicsTrainTest, ImagineStepEqualsPredictThenRewardsRowByRow) {
  for (const std::string variant :
       {"masked", "next_frame", "next_frame rope", "masked adaln", "next_frame rope adaln"}) {
    const std::string objective = variant.substr(0, variant.find(' '));
    std::string run = variant;
    std::replace(run.begin(), run.end(), ' ', '_');
    TrainOptions o = Options(run, 10);
    o.config.model.objective = objective;
    o.config.model.copy_prior = true;
    if (variant.find("rope") != std::string::npos) o.config.model.temporal_positions = "rope";
    if (variant.ends_with("adaln")) o.config.model.adaptive_norm = "identity";
    TrainDynamics(o);
    auto model = DynamicsModel::Load(dir_ / run);
    const int64_t n = model->tokens_per_frame(), rows = 3, frames = 3;
    FrameContext batch{.batch = rows, .frames = frames, .row_seeds = {5, 6, 7}};
    for (int64_t i = 0; i < rows * frames * n; ++i) batch.tokens.push_back((i * 7 + i / 5) % 32);
    for (int64_t i = 0; i < rows * frames * 7; ++i)
      batch.actions.push_back(0.01f * (i % 9) - 0.04f);
    const ImaginedSteps steps = model->ImagineStep(batch, 0, 4, 1.0);
    ASSERT_EQ(steps.tokens.size(), static_cast<size_t>(rows * n));
    for (int64_t b = 0; b < rows; ++b) {
      FrameContext row{.batch = 1, .frames = frames, .row_seeds = {batch.row_seeds[b]}};
      row.tokens.assign(batch.tokens.begin() + b * frames * n,
                        batch.tokens.begin() + (b + 1) * frames * n);
      row.actions.assign(batch.actions.begin() + b * frames * 7,
                         batch.actions.begin() + (b + 1) * frames * 7);
      const std::vector<int64_t> next = model->PredictNextFrame(row, 0, 4, 1.0);
      EXPECT_EQ(next, std::vector<int64_t>(steps.tokens.begin() + b * n,
                                           steps.tokens.begin() + (b + 1) * n))
          << variant << " row " << b;
      row.frames += 1;
      row.tokens.insert(row.tokens.end(), next.begin(), next.end());
      row.actions.insert(row.actions.end(), 7, 0.f);
      const RewardPrediction r = model->PredictRewards(row);
      EXPECT_NEAR(steps.reward[b], r.reward.back(), 1e-5) << variant << " row " << b;
      EXPECT_NEAR(steps.terminal_prob[b], r.terminal_prob.back(), 1e-5) << variant;
    }
  }
}

// The final step's reward (the only non-zero one, as on tabletop, where it comes with the frame
// showing success) must be a training target: a next-frame model then predicts it on the frame
// whose step earns it. Before position j was paired with step j, no window ever scored it.
TEST_F(DynamicsTrainTest, RewardHeadLearnsTheFinalStepsReward) {
  TrainOptions o = Options("run", 600);
  o.config.model.objective = "next_frame";
  TrainDynamics(o);
  auto model = DynamicsModel::Load(dir_ / "run");
  const tokens::TokenDataset data(dir_ / "tokens");
  const int64_t n = data.tokens_per_frame(), window = model->max_context_frames();
  std::vector<float> rewarded, unrewarded;  // predictions on each episode's last window
  for (int64_t k = 0; k < data.num_episodes(); ++k) {
    const int64_t frames = data.episode(k).num_frames,
                  first = std::max<int64_t>(0, frames - window);
    FrameContext c{.batch = 1, .frames = frames - first};
    c.tokens.resize(static_cast<size_t>(c.frames * n));
    data.CopyTokens(k, first, c.frames, c.tokens.data());
    c.actions.assign(data.actions(k) + first * 7, data.actions(k) + frames * 7);
    const RewardPrediction r = model->PredictRewards(c);
    for (int64_t t = 0; t < c.frames; ++t) {
      (data.rewards(k)[first + t] > 0.5f ? rewarded : unrewarded).push_back(r.reward[t]);
    }
  }
  ASSERT_GE(rewarded.size(), 5u);
  // AUROC: how often a rewarded step's prediction beats an unrewarded one's (0.5 = blind).
  double ordered = 0;
  for (float a : rewarded)
    for (float b : unrewarded) ordered += a > b ? 1.0 : (a == b ? 0.5 : 0.0);
  EXPECT_GT(ordered / (rewarded.size() * unrewarded.size()), 0.8)
      << rewarded.size() << " rewarded steps, " << unrewarded.size() << " others";
}

// A trained rotary-time model through the public API: rolling imagination gives ImagineStep's
// frames and rewards until the window slides (here context_frames 4: the first 3 steps), refuses
// a learned-position model naming its checkpoint, and the config key round-trips.
TEST_F(DynamicsTrainTest, RollingImaginationOfARotaryTimeModel) {
  TrainOptions o = Options("rope", 10);
  o.config.model.objective = "next_frame";
  o.config.model.copy_prior = true;
  o.config.model.temporal_positions = "rope";
  TrainDynamics(o);
  auto model = DynamicsModel::Load(dir_ / "rope");
  EXPECT_EQ(model->config().model.temporal_positions, "rope");
  ASSERT_TRUE(model->CanRoll());
  const int64_t n = model->tokens_per_frame(), rows = 2;
  std::vector<int64_t> first;
  for (int64_t i = 0; i < rows * n; ++i) first.push_back((i * 5) % 32);
  auto rolling = model->StartRolling(first, rows);
  std::vector<int64_t> tokens = first;  // [rows, t + 1, N] row-major per row below
  std::vector<std::vector<int64_t>> history(rows);
  std::vector<std::vector<float>> actions(rows);
  for (int64_t b = 0; b < rows; ++b)
    history[b].assign(first.begin() + b * n, first.begin() + (b + 1) * n);
  for (int64_t t = 0; t < model->max_context_frames(); ++t) {
    FrameContext window{
        .batch = rows, .frames = t + 1, .row_seeds = {uint64_t(40 + t), uint64_t(50 + t)}};
    std::vector<float> step;
    for (int64_t b = 0; b < rows; ++b) {
      for (int i = 0; i < 7; ++i) actions[b].push_back(0.01f * ((b + t + i) % 5) - 0.02f);
      step.insert(step.end(), actions[b].end() - 7, actions[b].end());
      window.tokens.insert(window.tokens.end(), history[b].begin(), history[b].end());
      window.actions.insert(window.actions.end(), actions[b].begin(), actions[b].end());
    }
    const ImaginedSteps want = model->ImagineStep(window, 0, 1, 1.0);
    const ImaginedSteps got = rolling->Step({0, 1}, step, window.row_seeds, 1.0);
    EXPECT_EQ(got.tokens, want.tokens) << "step " << t;
    for (int64_t b = 0; b < rows; ++b) {
      EXPECT_NEAR(got.reward[b], want.reward[b], 1e-5) << "step " << t;
      EXPECT_NEAR(got.terminal_prob[b], want.terminal_prob[b], 1e-5) << "step " << t;
      history[b].insert(history[b].end(), got.tokens.begin() + b * n,
                        got.tokens.begin() + (b + 1) * n);
    }
  }
  TrainDynamics(Options("learned", 2));
  EXPECT_NE(wm::test::ErrorText([&] {
              DynamicsModel::Load(dir_ / "learned")->StartRolling(first, rows);
            }).find("learned/checkpoint.wmt: rolling imagination needs"),
            std::string::npos);
  EXPECT_EQ(ConfigToJson(o.config)["model"]["temporal_positions"], "rope");
  EXPECT_FALSE(ConfigToJson(Options("x", 1).config)["model"].contains("temporal_positions"));
}

TEST(DynamicsConfig, PresetsLoadAndErrorsNameFileAndKey) {
  for (const char* name : {"tiny", "stable64", "meta64", "whale-x-small", "whale-x-medium",
                           "whale-x-base", "whale-x-large"}) {
    EXPECT_NO_THROW(
        LoadDynamicsConfig(wm::test::SourceDir() + "/configs/dynamics/" + name + ".yaml"))
        << name;
  }
  DynamicsConfig m = LoadDynamicsConfig(wm::test::SourceDir() + "/configs/dynamics/meta64.yaml");
  EXPECT_EQ(m.model.num_layers, 12);
  EXPECT_EQ(ConfigFromJson(ConfigToJson(m)).model.d_model, 512);
  // For configs/tokenizer/stable64.yaml's 64 codes, learning from scratch (no copy prior).
  DynamicsConfig s = LoadDynamicsConfig(wm::test::SourceDir() + "/configs/dynamics/stable64.yaml");
  EXPECT_EQ(s.model.num_codes, 64);
  EXPECT_FALSE(s.model.copy_prior);
  EXPECT_EQ(s.model.adaptive_norm, "identity");  // docs/dynamics.md, "Adaptive norm on stable64"
  auto error = [](const std::string& yaml) {
    return wm::test::ErrorText([&] { ParseDynamicsConfig(yaml, "dyn.yaml"); });
  };
  EXPECT_EQ(error("model:\n  d_model: 100\n  num_heads: 8\n"),
            "dyn.yaml: key 'model.d_model': must be a positive multiple of model.num_heads");
  EXPECT_NE(error("model:\n  num_layers: many\n").find("dyn.yaml: key 'model.num_layers'"),
            std::string::npos);
  EXPECT_NE(error("policy:\n  klbeta: 1\n").find("key 'policy.klbeta': unknown key"),
            std::string::npos);
  EXPECT_NE(error("model:\n  norm: batchnorm\n").find("key 'model.norm'"), std::string::npos);
  EXPECT_NE(error("model:\n  objective: diffusion\n").find("key 'model.objective'"),
            std::string::npos);
  EXPECT_NE(error("model:\n  temporal_positions: alibi\n")
                .find("key 'model.temporal_positions': must be 'learned' or 'rope'"),
            std::string::npos);
  EXPECT_NE(error("model:\n  adaptive_norm: film\n")
                .find("key 'model.adaptive_norm': must be 'none', 'identity' or 'zero'"),
            std::string::npos);
  // Configs without adaLN keep their bytes and hashes; with it the key is stored.
  EXPECT_FALSE(ConfigToJson(m)["model"].contains("adaptive_norm"));
  DynamicsConfig zero = m;
  zero.model.adaptive_norm = "zero";
  EXPECT_EQ(ConfigFromJson(ConfigToJson(zero)).model.adaptive_norm, "zero");
  // A checkpoint written before model.objective / model.copy_prior existed keeps its behaviour.
  nlohmann::json old = ConfigToJson(m);
  old["model"].erase("objective");
  old["model"].erase("copy_prior");
  EXPECT_EQ(ConfigFromJson(old).model.objective, "masked");
  EXPECT_FALSE(ConfigFromJson(old).model.copy_prior);
  EXPECT_NE(error("optim: {}\n").find("key 'optim'"), std::string::npos);
  EXPECT_NE(error("model: [1\n").find("dyn.yaml"), std::string::npos);
}

TEST(DistributedEnvironment, TorchrunVariablesSetRankAndTheLocalGpu) {
  setenv("RANK", "3", 1);
  setenv("WORLD_SIZE", "4", 1);
  setenv("LOCAL_RANK", "1", 1);
  setenv("MASTER_ADDR", "node7", 1);
  TrainOptions o;
  o.device = "cuda";
  ReadDistributedEnvironment(o);
  EXPECT_EQ(o.rank, 3);
  EXPECT_EQ(o.world_size, 4);
  EXPECT_EQ(o.master_addr, "node7");
  EXPECT_EQ(o.device, "cuda:1");
  EXPECT_FALSE(o.show_progress);
  EXPECT_TRUE(o.launched);  // a process group even where WORLD_SIZE is 1 (torchrun's way)
  TrainOptions pinned;
  pinned.device = "cuda:0";  // an explicit index is kept
  ReadDistributedEnvironment(pinned);
  EXPECT_EQ(pinned.device, "cuda:0");
  setenv("RANK", "4", 1);
  EXPECT_NE(wm::test::ErrorText([&] { ReadDistributedEnvironment(o); }).find("RANK"),
            std::string::npos);
  for (const char* v : {"RANK", "WORLD_SIZE", "LOCAL_RANK", "MASTER_ADDR"}) unsetenv(v);
  TrainOptions plain;
  ReadDistributedEnvironment(plain);
  EXPECT_FALSE(plain.launched);
  EXPECT_EQ(plain.world_size, 1);
}

TEST(LearningRate, AdaptsTheTokenizerSchedule) {
  TrainConfig t;
  t.max_lr = 1.0;
  t.min_lr = 0.1;
  t.warmup_steps = 10;
  t.steps = 110;
  EXPECT_DOUBLE_EQ(LearningRateAt(t, 0), 0.1);
  EXPECT_NEAR(LearningRateAt(t, 60), 0.55, 1e-12);
  EXPECT_NEAR(LearningRateAt(t, 110), 0.1, 1e-12);
}

}  // namespace
}  // namespace wm::train

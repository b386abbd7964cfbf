// wm-eval of a motion checkpoint (evaluate/imagination.h): a motion model trained in seconds on
// the moving-square data (tests/motion/moving_square.h) is scored beside the baselines of a tiny
// tokenizer of the same frames, with its plain rollout only; it follows its actions (delta_tpsnr)
// and beats copying; two shard jobs write the single job's report; the closed loop's rollout,
// stepped, is the open-loop one exactly; the closed loop without a success classifier
// and a model of another image size are refused.
#include <gtest/gtest.h>

#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/sha256.h"
#include "evaluate/evaluator.h"
#include "metrics/value/csv_table.h"
#include "motion/motion_model.h"
#include "motion/trainer.h"
#include "tests/core/test_util.h"
#include "tests/motion/moving_square.h"
#include "tests/tokenize/shapes_fixture.h"
#include "tokenize/encode.h"
#include "tokenize/trainer.h"

namespace wm::evaluate {
namespace {

constexpr int64_t kHorizon = 6;

class MotionEvalTest : public ::testing::Test {
 protected:
  // Shards, a tokenizer (5 steps: it only gives the baselines and features), the val episodes
  // as a token dataset, a motion model (150 steps), and the unsharded report.
  static void SetUpTestSuite() {
    dir_ = new test::TempDir();
    motion::test::WriteMovingSquares(*dir_ / "train", 24, 12, 1);
    motion::test::WriteMovingSquares(*dir_ / "val", 4, 9, 99, "moving_square_val");
    tokenize::TrainOptions tok{
        .config = tokenize::TestConfig(), .data_dirs = {*dir_ / "train"}, .out_dir = *dir_ / "tok"};
    tok.config.train.steps = 5;
    tok.show_progress = false;
    tokenize::TrainTokenizer(tok);
    tokenize::EncodeDataset({.checkpoint = *dir_ / "tok",
                             .data_dir = *dir_ / "val",
                             .out_dir = *dir_ / "tokens",
                             .show_progress = false});
    motion::TrainOptions m{.config = motion::test::TestConfig(),
                           .data_dir = *dir_ / "train",
                           .out_dir = *dir_ / "motion"};
    m.config.model.kind = "layers";  // the demo's kind (the trainer's tests cover both)
    m.config.train.steps = 150;
    m.show_progress = false;
    motion::TrainMotion(m);
    EvaluateCheckpoints(Options("single"));
  }
  static void TearDownTestSuite() { delete dir_; }

  // As wm-eval --rollout auto on eef_delta data (plain and retrace) would run it.
  static EvalOptions Options(const std::string& out) {
    EvalOptions o;
    o.checkpoints = {*dir_ / "motion"};
    o.tokenizer = *dir_ / "tok";
    o.data_dir = *dir_ / "val";
    o.tokens_dir = *dir_ / "tokens";
    o.out_dir = *dir_ / out;
    o.rollout_auto = true;
    o.rollout.horizon = kHorizon;
    o.resamples = 100;
    o.videos = 0;
    o.strips = 0;
    o.show_progress = false;
    return o;
  }
  static std::string Report(const std::string& out, const std::string& file) {
    return *dir_ / (out + "/motion/" + file);
  }
  // summary.csv's mean of (rollout, metric); every row's rollout into `rollouts`.
  static std::map<std::pair<std::string, std::string>, std::string> Summary(
      std::set<std::string>* rollouts) {
    const auto t = metrics::CsvTable::Read(Report("single", "summary.csv"));
    std::map<std::pair<std::string, std::string>, std::string> means;
    for (size_t r = 0; r < t.rows(); ++r) {
      rollouts->insert(t.Cell(r, t.Column("rollout")));
      means[{t.Cell(r, t.Column("rollout")), t.Cell(r, t.Column("metric"))}] =
          t.Cell(r, t.Column("mean"));
    }
    return means;
  }

  static test::TempDir* dir_;
};
test::TempDir* MotionEvalTest::dir_ = nullptr;

TEST_F(MotionEvalTest, PlainRolloutBesideTheBaselinesFollowsTheActionsAndBeatsCopying) {
  std::set<std::string> rollouts;
  const auto mean = Summary(&rollouts);
  EXPECT_EQ(rollouts,
            (std::set<std::string>{"plain", "copy_last", "copy_last_tokens", "tokenizer_recon"}));
  ASSERT_TRUE(mean.contains({"plain", "delta_tpsnr"}));
  const double delta_tpsnr = std::stod(mean.at({"plain", "delta_tpsnr"}));
  const double psnr = std::stod(mean.at({"plain", "psnr"}));
  const double copy_last = std::stod(mean.at({"copy_last", "psnr"}));
  std::printf("motion model: psnr %.2f dB, copy_last %.2f dB, delta_tpsnr %.2f dB\n", psnr,
              copy_last, delta_tpsnr);
  EXPECT_GT(delta_tpsnr, 1);
  EXPECT_GT(psnr, copy_last);
  // No reward head, no token contexts: the two files keep their headers only.
  EXPECT_EQ(ReadFile(Report("single", "values.csv")),
            "checkpoint,rollout,policy_id,n_episodes,real_value,model_value,value_gap\n");
  EXPECT_EQ(ReadFile(Report("single", "contexts.csv")),
            "checkpoint,rollout,episode,step,slot,frame,a0,a1,a2,a3,a4,a5,a6\n");
  const auto m = nlohmann::json::parse(ReadFile(Report("single", "manifest.json")));
  EXPECT_EQ(m["checkpoint"]["model_kind"], "motion");
  EXPECT_EQ(m["checkpoint"]["sha256"], Sha256File(*dir_ / "motion/checkpoint.wmt"));
  EXPECT_EQ(m["checkpoint"]["step"], 150);
  EXPECT_EQ(m["checkpoint"]["config"]["model"]["image_size"], 32);
  EXPECT_EQ(m["config"]["rollouts"], nlohmann::json::array({"plain"}));
}

// Also with retrace asked for explicitly (it is skipped with a warning): the same report.
TEST_F(MotionEvalTest, TwoShardJobsWriteTheSingleJobsReport) {
  EvalOptions o = Options("sharded");
  o.rollout_auto = false;
  o.num_shards = 2;
  o.shard_index = 1;
  EXPECT_TRUE(EvaluateCheckpoints(o).empty()) << "part 0 is missing";
  o.shard_index = 0;
  EXPECT_EQ(EvaluateCheckpoints(o).size(), 1u);
  for (const char* file : {"summary.csv", "per_episode.csv", "per_step.csv", "manifest.json"}) {
    EXPECT_EQ(ReadFile(Report("sharded", file)), ReadFile(Report("single", file))) << file;
  }
}

// The closed loop imagines with a Rollout, one step at a time: under the same actions its frames
// are Imagine's, bit for bit (so a policy that repeats the logged actions sees the open-loop
// rollout).
TEST_F(MotionEvalTest, RolloutStepsAreImagine) {
  const auto model = motion::MotionModel::Load(*dir_ / "motion");
  const int64_t S = model->image_size(), D = model->action_dim(), H = 5;
  std::vector<float> first(static_cast<size_t>(3 * S * S)), actions(static_cast<size_t>(H * D));
  for (size_t i = 0; i < first.size(); ++i) first[i] = static_cast<float>((i * 37) % 200) / 100 - 1;
  for (size_t i = 0; i < actions.size(); ++i) actions[i] = (i % 3 == 0 ? 1.0f : -0.5f);
  const std::vector<float> open_loop = model->Imagine(first, actions, 1, H);
  const auto rollout = model->StartRollout(first, 1);
  std::vector<float> stepped;
  for (int64_t t = 0; t < H; ++t) {
    const std::vector<float> next =
        rollout->Next(std::vector<float>(actions.begin() + t * D, actions.begin() + (t + 1) * D));
    stepped.insert(stepped.end(), next.begin(), next.end());
  }
  EXPECT_EQ(stepped, open_loop);
  EXPECT_NE(std::vector<float>(open_loop.begin(), open_loop.begin() + 3 * S * S), first);
  EXPECT_THROW(rollout->Next(std::vector<float>(D + 1)), Error);
  EXPECT_THROW(model->StartRollout(std::vector<float>(3 * S * S - 1), 1), Error);
}

// One line each: the closed loop without --success-model (no reward head), and frames of another
// size than the tokenizer's (a motion model trained at 64 pixels against the 32-pixel tokenizer).
TEST_F(MotionEvalTest, RefusesThePolicyLoopWithoutASuccessModelAndAnotherImageSize) {
  EvalOptions o = Options("refused");
  o.policy_eval.policies = {{.name = "random", .command = "true", .in_distribution = true}};
  std::string error = test::ErrorText([&] { EvaluatePolicies(o); });
  EXPECT_NE(error.find("needs --success-model"), std::string::npos) << error;
  EXPECT_EQ(error.find('\n'), std::string::npos) << error;

  motion::TrainOptions m{.config = motion::test::TestConfig(),
                         .data_dir = *dir_ / "train",
                         .out_dir = *dir_ / "motion64"};
  m.config.model.image_size = 64;
  m.config.train.steps = 1;
  m.show_progress = false;
  motion::TrainMotion(m);
  o = Options("refused");
  o.checkpoints = {*dir_ / "motion64"};
  error = test::ErrorText([&] { EvaluateCheckpoints(o); });
  EXPECT_NE(error.find("imagines 64x64 frames, but --tokenizer scores 32x32"), std::string::npos)
      << error;
}

}  // namespace
}  // namespace wm::evaluate

// The motion model's closed loop imagined as one batch (MotionWorldBatches, wm-eval --policy)
// against one episode at a time (MotionWorlds): a motion model and a success classifier trained in
// seconds on the moving-square data (tests/motion/moving_square.h), the random tabletop policy
// (its actions differ per episode), starts that end at different steps. The frames are the same
// up to float rounding (kPixelTolerance: LibTorch's CPU conv/GEMM kernels may round a row
// differently in another batch shape), the actions, steps, ends and successes exactly.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <set>

#include "core/shard/dataset_reader.h"
#include "evaluate/clip_decode.h"
#include "evaluate/closed_loop.h"
#include "motion/motion_model.h"
#include "motion/trainer.h"
#include "policy/policy_process.h"
#include "success/success_model.h"
#include "success/trainer.h"
#include "tests/core/test_util.h"
#include "tests/motion/moving_square.h"

namespace wm::evaluate {
namespace {

constexpr int kStarts = 6;
constexpr int64_t kHorizon = 8;
// Of pixels in [-1, 1] and of P(success): float rounding of other batch shapes, nothing more
// (measured: 5e-6 and 6e-8 on this test's 8 steps).
constexpr double kPixelTolerance = 1e-4, kRewardTolerance = 1e-5;

class MotionClosedLoopTest : public ::testing::Test {
 protected:
  // Moving squares, a motion model of the demo's kind (40 steps) and a success classifier
  // (20 steps; the last step of each episode is its success): what they imagine and score need
  // not be good, only deterministic and different per start and step.
  static void SetUpTestSuite() {
    dir_ = new test::TempDir();
    motion::test::WriteMovingSquares(*dir_ / "train", 16, 10, 1);
    motion::test::WriteMovingSquares(*dir_ / "val", kStarts, 4, 99, "moving_square_val");
    motion::TrainOptions m{.config = motion::test::TestConfig(),
                           .data_dir = *dir_ / "train",
                           .out_dir = *dir_ / "motion"};
    m.config.model.kind = "layers";
    m.show_progress = false;
    motion::TrainMotion(m);
    success::TrainOptions s;
    s.data_dir = *dir_ / "train";
    s.out_dir = *dir_ / "success";
    s.config.model = {.image_size = 32, .channels = 8};
    s.config.train.batch_size = 16;
    s.config.train.steps = 20;
    s.config.train.warmup_steps = 5;
    s.config.train.checkpoint_every = 20;
    s.show_progress = false;
    success::TrainSuccess(s);
    model_ = motion::MotionModel::Load(*dir_ / "motion").release();
    success_ = success::SuccessModel::Load(*dir_ / "success").release();
  }
  static void TearDownTestSuite() {
    delete model_;
    delete success_;
    delete dir_;
  }

  // The val episodes' real first frames.
  static std::vector<ClosedLoopStart> Starts() {
    const shard::DatasetReader shards(*dir_ / "val");
    std::vector<ClosedLoopStart> starts;
    starts.reserve(kStarts);
    for (int k = 0; k < kStarts; ++k) {
      starts.push_back(
          {.episode = k,
           .episode_seed = MixSeed(11, k),
           .first_frame = RealClip(shards.ReadEpisode(static_cast<size_t>(k)), "image", 32, 1)});
    }
    return starts;
  }

  // Every start's rollout 0 in `worlds`, all in one lockstep batch.
  static std::vector<ClosedLoopRollout> Run(const WorldsFactory& worlds,
                                            const std::vector<ClosedLoopStart>& starts,
                                            const ClosedLoopOptions& o) {
    const char* src = std::getenv("WM_SOURCE_DIR");
    policy::PolicyProcess policy({.name = "random",
                                  .command = "/usr/bin/python3 " + std::string(src ? src : ".") +
                                             "/scripts/tabletop_colour_policy.py --random",
                                  .action_dim = static_cast<int>(model_->action_dim()),
                                  .image_height = 32,
                                  .image_width = 32});
    std::vector<const ClosedLoopStart*> all;
    all.reserve(starts.size());
    for (const ClosedLoopStart& s : starts) all.push_back(&s);
    return RunClosedLoops(*worlds(all, 0), policy, all, 0, o);
  }

  // A success threshold among the middle half of the step scores of `rollouts` (run to the
  // horizon), halfway across their widest gap there: the starts cross it at different steps, and
  // no score sits within rounding of it.
  static double ThresholdBetweenScores(const std::vector<ClosedLoopRollout>& rollouts) {
    std::vector<float> scores;
    for (const ClosedLoopRollout& r : rollouts) {
      scores.insert(scores.end(), r.rewards.begin(), r.rewards.end());
    }
    std::sort(scores.begin(), scores.end());
    size_t widest = scores.size() / 4;
    for (size_t i = widest; i + 1 < scores.size() * 3 / 4; ++i) {
      if (scores[i + 1] - scores[i] > scores[widest + 1] - scores[widest]) widest = i;
    }
    EXPECT_GT(scores[widest + 1] - scores[widest], 2 * kRewardTolerance);
    return (static_cast<double>(scores[widest]) + scores[widest + 1]) / 2;
  }

  static test::TempDir* dir_;
  static const motion::MotionModel* model_;
  static const success::SuccessModel* success_;
};
test::TempDir* MotionClosedLoopTest::dir_ = nullptr;
const motion::MotionModel* MotionClosedLoopTest::model_ = nullptr;
const success::SuccessModel* MotionClosedLoopTest::success_ = nullptr;

double MaxAbsDiff(const std::vector<float>& a, const std::vector<float>& b) {
  double most = 0;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) {
    most = std::max<double>(most, std::abs(a[i] - b[i]));
  }
  return most;
}

TEST_F(MotionClosedLoopTest, OneBatchImaginesWhatOneEpisodeAtATimeDoes) {
  const std::vector<ClosedLoopStart> starts = Starts();
  ClosedLoopOptions o{.horizon = kHorizon};
  o.success_threshold = std::numeric_limits<double>::infinity();
  const WorldsFactory one_by_one = WorldsInTurn(MotionWorlds(*model_, *success_));
  o.success_threshold = ThresholdBetweenScores(Run(one_by_one, starts, o));
  const std::vector<ClosedLoopRollout> ref = Run(one_by_one, starts, o);
  const std::vector<ClosedLoopRollout> batched =
      Run(MotionWorldBatches(*model_, *success_), starts, o);

  ASSERT_EQ(batched.size(), ref.size());
  std::set<int64_t> lengths;
  double pixel = 0, reward = 0;
  for (size_t k = 0; k < ref.size(); ++k) {
    const ClosedLoopRollout &a = ref[k], &b = batched[k];
    SCOPED_TRACE("start " + std::to_string(k));
    lengths.insert(a.steps);
    EXPECT_EQ(b.steps, a.steps);
    EXPECT_EQ(b.end, a.end);
    EXPECT_EQ(b.success, a.success);
    EXPECT_EQ(b.actions, a.actions);
    EXPECT_EQ(b.terminal_probs, a.terminal_probs);
    ASSERT_EQ(b.frames.frames, a.frames.frames);
    ASSERT_EQ(b.rewards.size(), a.rewards.size());
    pixel = std::max(pixel, MaxAbsDiff(b.frames.pixels, a.frames.pixels));
    reward = std::max(reward, MaxAbsDiff(b.rewards, a.rewards));
  }
  std::printf("batched vs one at a time: max |pixel diff| %.3g, max |reward diff| %.3g\n", pixel,
              reward);
  EXPECT_LE(pixel, kPixelTolerance);
  EXPECT_LE(reward, kRewardTolerance);
  // Rows left the batch at different steps.
  std::printf("episode lengths: %zu distinct\n", lengths.size());
  EXPECT_GE(lengths.size(), 3u);
}

// Some world's steps: each running row's start frame, with a reward and terminal of its own.
class FixedFrames : public ImaginedWorlds {
 public:
  explicit FixedFrames(const std::vector<const ClosedLoopStart*>& starts) : starts_(starts) {}
  std::vector<ImaginedStep> Next(const std::vector<size_t>& rows,
                                 const std::vector<const std::vector<float>*>&, int64_t) override {
    std::vector<ImaginedStep> out;
    for (size_t row : rows) {
      out.push_back({.frame = starts_[row]->first_frame, .reward = 7, .terminal_prob = 0.9f});
    }
    return out;
  }

 private:
  std::vector<const ClosedLoopStart*> starts_;
};

// A token model judged by the classifier: the rows' frames pass through, each step's score is the
// classifier's P(success) of that row's frame (its own call on the frame alone gives the same),
// and the inner world's reward and terminal are dropped.
TEST_F(MotionClosedLoopTest, ScoredBySuccessScoresEachRunningRowsFrameWithTheClassifier) {
  const std::vector<ClosedLoopStart> starts = Starts();
  std::vector<const ClosedLoopStart*> all;
  for (const ClosedLoopStart& s : starts) all.push_back(&s);
  const WorldsFactory scored = ScoredBySuccess(
      [](const std::vector<const ClosedLoopStart*>& rows, int) -> std::unique_ptr<ImaginedWorlds> {
        return std::make_unique<FixedFrames>(rows);
      },
      *success_);
  const std::vector<size_t> rows = {1, 4, 5};
  const std::vector<float> no_actions;
  const std::vector<ImaginedStep> steps =
      scored(all, 0)->Next(rows, {&no_actions, &no_actions, &no_actions}, 0);
  ASSERT_EQ(steps.size(), rows.size());
  std::set<float> distinct;
  for (size_t k = 0; k < rows.size(); ++k) {
    const Clip& frame = starts[rows[k]].first_frame;
    EXPECT_EQ(steps[k].frame.pixels, frame.pixels);
    EXPECT_EQ(steps[k].terminal_prob, 0);
    const float alone = success_->Probabilities(frame.pixels, 1).front();
    EXPECT_NEAR(steps[k].reward, alone, kRewardTolerance);
    EXPECT_GE(steps[k].reward, 0);
    EXPECT_LE(steps[k].reward, 1);
    distinct.insert(steps[k].reward);
  }
  EXPECT_GE(distinct.size(), 2u);  // the rows' own frames, not one score for all
}

}  // namespace
}  // namespace wm::evaluate

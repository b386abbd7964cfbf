// The success classifier through its torch-free API (trainer.h, success_model.h,
// labelled_frames.h): AUROC on hand-made scores, config errors, byte-identical seeds and resume,
// and that it learns a separable toy case: 32x32 frames of a red square on a brown table, a
// success (reward 1, the last step of each episode) exactly when the square sits on the blue disc.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>

#include "core/error.h"
#include "core/image_codec.h"
#include "core/sha256.h"
#include "core/shard/dataset_writer.h"
#include "success/config.h"
#include "success/labelled_frames.h"
#include "success/score.h"
#include "success/success_model.h"
#include "success/trainer.h"
#include "tests/core/test_util.h"
#include "trainkit/frame_decode.h"

namespace wm::success {
namespace {

constexpr int kSize = 32, kSquare = 6, kDiscU = 22, kDiscV = 16;

std::vector<uint8_t> Rgb(int x, int y) {
  std::vector<uint8_t> rgb(kSize * kSize * 3);
  for (int v = 0; v < kSize; ++v) {
    for (int u = 0; u < kSize; ++u) {
      std::array<int, 3> colour = {120, 100, 80};
      if ((u - kDiscU) * (u - kDiscU) + (v - kDiscV) * (v - kDiscV) <= 36) colour = {40, 60, 200};
      if (u >= x && u < x + kSquare && v >= y && v < y + kSquare) colour = {220, 30, 30};
      for (int c = 0; c < 3; ++c) rgb[(v * kSize + u) * 3 + c] = static_cast<uint8_t>(colour[c]);
    }
  }
  return rgb;
}

// Episodes whose square wanders on the left half and, at the last step, sits on the disc
// (MakeEpisode logs reward 1 there); with `never_succeed` every reward is 0.
void WriteSquaresOnDisc(const std::string& dir, int episodes, int steps, uint64_t seed,
                        bool never_succeed = false) {
  shard::DatasetWriter writer({.dir = dir, .config_hash = "success-test"});
  std::mt19937_64 rng(seed);
  for (int e = 0; e < episodes; ++e) {
    Episode ep = test::MakeEpisode(steps, seed + e, "squares" + std::to_string(e));
    std::vector<std::string> frames;
    for (int t = 0; t < steps; ++t) {
      const bool last = t == steps - 1;
      const int x = last ? kDiscU - kSquare / 2 : static_cast<int>(rng() % 10);
      const int y = last ? kDiscV - kSquare / 2 : static_cast<int>(rng() % (kSize - kSquare));
      frames.push_back(EncodePng(Rgb(x, y).data(), kSize, kSize, 3));
      if (never_succeed) ep.rewards[t] = 0;
    }
    test::SetPngFrames(ep, std::move(frames), kSize);
    writer.Add(ep, e);
  }
  test::FinishTrainSplit(writer, "squares");
}

std::vector<float> Planar(int x, int y) {
  std::vector<float> out(3 * kSize * kSize);
  trainkit::Rgb8ToPlanar(Rgb(x, y).data(), kSize, kSize, kSize, out.data());
  return out;
}

class SuccessTest : public ::testing::Test {
 protected:
  void SetUp() override {
    WriteSquaresOnDisc(dir_ / "train", 24, 8, 1);
    WriteSquaresOnDisc(dir_ / "val", 8, 8, 77);
  }

  TrainOptions Options(const std::string& out, int64_t steps) const {
    TrainOptions o;
    o.config.model = {.image_size = kSize, .channels = 8};
    o.config.train.batch_size = 16;
    o.config.train.steps = steps;
    o.config.train.warmup_steps = 5;
    o.config.train.checkpoint_every = 10;
    o.config.train.log_every = 5;
    o.config.train.seed = 3;
    o.data_dir = dir_ / "train";
    o.out_dir = dir_ / out;
    o.show_progress = false;
    return o;
  }

  test::TempDir dir_;
};

TEST(AurocTest, CountsOrderedPairsAndHalfTies) {
  EXPECT_DOUBLE_EQ(Auroc({0.1f, 0.4f, 0.35f, 0.8f}, {0, 0, 1, 1}), 0.75);
  EXPECT_DOUBLE_EQ(Auroc({0.9f, 0.8f, 0.1f}, {1, 1, 0}), 1.0);
  EXPECT_DOUBLE_EQ(Auroc({0.9f, 0.8f, 0.1f}, {0, 0, 1}), 0.0);
  EXPECT_DOUBLE_EQ(Auroc({0.5f, 0.5f, 0.2f}, {0, 1, 0}), 0.75);
  EXPECT_TRUE(std::isnan(Auroc({0.5f, 0.7f}, {1, 1})));
}

TEST(SuccessConfigTest, OutOfRangeValuesNameTheKey) {
  try {
    ParseSuccessConfig("train:\n  positive_fraction: 1.5\n", "bad.yaml");
    FAIL() << "accepted positive_fraction 1.5";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("train.positive_fraction"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ParseSuccessConfig("model:\n  chanels: 8\n", "typo.yaml"), Error);
  const SuccessConfig c = ParseSuccessConfig("model:\n  channels: 8\n", "ok.yaml");
  EXPECT_EQ(ConfigToJson(ConfigFromJson(ConfigToJson(c))), ConfigToJson(c));
}

TEST_F(SuccessTest, BalancedBatchesAreAPureFunctionOfSeedAndStep) {
  const LabelledFrames frames(dir_ / "train", "image", kSize, 0.5, true);
  EXPECT_EQ(frames.positives(), 24);
  EXPECT_EQ(frames.negatives(), 24 * 7);
  const std::vector<FrameRef> a = frames.Draw(1, 7, 16, 0.25), b = frames.Draw(1, 7, 16, 0.25);
  int positives = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].episode, b[i].episode);
    EXPECT_EQ(a[i].step, b[i].step);
    positives += a[i].success;
  }
  EXPECT_EQ(positives, 4);
}

TEST_F(SuccessTest, LearnsTheSeparableToyCase) {
  TrainOptions o = Options("run", 120);
  o.val_dir = dir_ / "val";
  const TrainSummary s = TrainSuccess(o);
  ASSERT_TRUE(s.val.has_value());
  EXPECT_GT(s.val->auroc, 0.95);
  EXPECT_GT(s.val->accuracy, s.val->majority_accuracy);
  EXPECT_DOUBLE_EQ(s.val->majority_accuracy, 7.0 / 8.0);
  EXPECT_GE(s.val->episode_accuracy, 0.75);
  EXPECT_LT(s.last_loss, s.first_loss);

  const auto model = SuccessModel::Load(dir_ / "run");
  EXPECT_TRUE(SuccessModel::IsSuccessCheckpoint(dir_ / "run"));
  std::vector<float> frames = Planar(kDiscU - kSquare / 2, kDiscV - kSquare / 2);  // on the disc
  const std::vector<float> off = Planar(2, 3);
  frames.insert(frames.end(), off.begin(), off.end());
  const std::vector<float> p = model->Probabilities(frames, 2);
  ASSERT_EQ(p.size(), 2u);
  EXPECT_GT(p[0], 0.5f);
  EXPECT_LT(p[1], 0.5f);
  EXPECT_THROW(model->Probabilities(off, 2), Error);

  // Every val episode ends with the square on the disc (its one success frame, the last).
  const std::vector<EpisodeScore> scores = ScoreEpisodes(*model, dir_ / "val");
  ASSERT_EQ(scores.size(), 8u);
  int right = 0;
  for (const EpisodeScore& e : scores) {
    EXPECT_TRUE(e.logged_success);
    EXPECT_EQ(e.steps, 8);
    EXPECT_EQ(e.predicted_success, e.first_success_step >= 0);
    EXPECT_EQ(e.predicted_success, e.max_probability > 0.5);
    right += e.first_success_step == 7;
  }
  EXPECT_GE(right, 6);
  EXPECT_EQ(ScoresCsv(scores).substr(0, ScoresCsv(scores).find('\n')),
            "episode,policy_id,steps,logged_success,predicted_success,first_success_step,"
            "max_probability");
}

TEST_F(SuccessTest, SameSeedIdenticalAndResumeReachesTheSameBytes) {
  TrainSuccess(Options("a", 30));
  TrainSuccess(Options("b", 30));
  EXPECT_EQ(Sha256File(dir_ / "a/checkpoint.wmt"), Sha256File(dir_ / "b/checkpoint.wmt"));
  TrainOptions first = Options("c", 30);
  first.max_steps_this_run = 20;
  TrainSuccess(first);
  TrainOptions rest = Options("c", 30);
  rest.resume = true;
  EXPECT_EQ(TrainSuccess(rest).start_step, 20);
  EXPECT_EQ(Sha256File(dir_ / "a/checkpoint.wmt"), Sha256File(dir_ / "c/checkpoint.wmt"));
}

TEST_F(SuccessTest, RefusesDataWithoutSuccessFramesAndOtherCheckpoints) {
  WriteSquaresOnDisc(dir_ / "never", 4, 5, 2, /*never_succeed=*/true);
  TrainOptions o = Options("never_run", 10);
  o.data_dir = dir_ / "never";
  try {
    TrainSuccess(o);
    FAIL() << "trained without success frames";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("0 success frames"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(SuccessModel::IsSuccessCheckpoint(dir_ / "nothing_here"));
  EXPECT_THROW(SuccessModel::Load(dir_ / "nothing_here"), Error);
}

}  // namespace
}  // namespace wm::success

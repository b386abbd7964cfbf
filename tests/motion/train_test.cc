// The motion model's trainer through the torch-free trainer.h and motion_model.h: determinism,
// byte-identical resume, config errors, and that it learns motion that follows the actions on
// the moving-square data (moving_square.h), scored against copying and reversed actions.
#include <gtest/gtest.h>

#include <cmath>

#include "core/atomic_file.h"
#include "core/sha256.h"
#include "motion/motion_model.h"
#include "motion/trainer.h"
#include "motion/window_sampler.h"
#include "tests/core/test_util.h"
#include "tests/motion/moving_square.h"

namespace wm::motion {
namespace {

// metrics.csv without its last column (frames per second: wall-clock time).
std::string WithoutThroughput(const std::string& csv) {
  std::string out;
  size_t start = 0;
  while (start < csv.size()) {
    const size_t end = csv.find('\n', start);
    const std::string line = csv.substr(start, end - start);
    out += line.substr(0, line.rfind(',')) + "\n";
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return out;
}

// Every test of the trainer and the API runs for each model kind (model.kind), and for the
// layered kind with the motion prior on a textured background (configs/motion/textured.yaml's
// case): the prior's weight changes over the steps, so resume is checked across it. The pose
// kind runs as many dynamics steps (3-step rollouts) after its autoencoder's.
class MotionTrainTest : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    test::WriteMovingSquares(dir_ / "train", 24, 12, 1, "moving_square", Textured());
    test::WriteMovingSquares(dir_ / "val", 6, 9, 99, "moving_square_val", Textured());
  }

  // "textured_prior": the layered kind with the motion prior on squares over a checkerboard
  // (configs/motion/textured.yaml's case; on the flat background the prior costs: 27.1 dB vs
  // copying's 27.5 after 300 steps)
  bool Textured() const { return GetParam() == "textured_prior"; }

  TrainOptions Options(const std::string& out, int64_t steps) const {
    TrainOptions o;
    o.config = test::TestConfig();
    o.config.model.kind = Textured() ? "layers" : GetParam();
    if (Textured()) {  // textured.yaml's prior: weight 1 fading over the first 0.2 of the steps
      o.config.train.motion_prior = 1;
      o.config.train.motion_prior_steps = 0.2;
      o.config.train.moved_weight = 4;  // and its weighted frame loss
    }
    o.config.train.steps = steps;
    if (GetParam() == "pose") {
      o.config.train.dynamics_steps = steps;
      o.config.train.unroll = 3;
      o.config.train.moved_weight = 4;  // configs/motion/pose.yaml's (without, the alpha dies)
      o.config.train.calibrate_alpha = true;  // after the last step: resumed runs must match
    }
    o.data_dir = dir_ / "train";
    o.out_dir = dir_ / out;
    o.show_progress = false;
    return o;
  }

  wm::test::TempDir dir_;
};

TEST_P(MotionTrainTest, SameSeedGivesIdenticalCheckpoints) {
  TrainMotion(Options("a", 20));
  TrainMotion(Options("b", 20));
  EXPECT_EQ(Sha256File(dir_ / "a/checkpoint.wmt"), Sha256File(dir_ / "b/checkpoint.wmt"));
  TrainOptions other = Options("c", 20);
  other.config.train.seed = 6;
  TrainMotion(other);
  EXPECT_NE(Sha256File(dir_ / "a/checkpoint.wmt"), Sha256File(dir_ / "c/checkpoint.wmt"));
}

TEST_P(MotionTrainTest, KilledRunResumesBitIdentically) {
  TrainMotion(Options("whole", 30));
  TrainOptions part = Options("parts", 30);
  // not a checkpoint_every multiple (the stop writes one), inside the motion prior's 6 steps
  part.max_steps_this_run = 3;
  EXPECT_EQ(TrainMotion(part).end_step, 3);
  part.resume = true;
  const int64_t end = GetParam() == "pose" ? 60 : 30;
  if (GetParam() == "pose") {  // and stopped again inside the dynamics' phase
    part.max_steps_this_run = 40;
    EXPECT_EQ(TrainMotion(part).end_step, 43);
  }
  part.max_steps_this_run = 0;
  const TrainSummary rest = TrainMotion(part);
  EXPECT_EQ(rest.start_step, GetParam() == "pose" ? 43 : 3);
  EXPECT_EQ(rest.end_step, end);
  EXPECT_EQ(Sha256File(dir_ / "whole/checkpoint.wmt"), Sha256File(dir_ / "parts/checkpoint.wmt"));
  EXPECT_EQ(WithoutThroughput(ReadFile(dir_ / "whole/metrics.csv")),
            WithoutThroughput(ReadFile(dir_ / "parts/metrics.csv")));
  // A finished run resumed has no step left: nothing changes (the alpha is not shifted twice).
  const std::string finished = Sha256File(dir_ / "parts/checkpoint.wmt");
  EXPECT_EQ(TrainMotion(part).end_step, end);
  EXPECT_EQ(Sha256File(dir_ / "parts/checkpoint.wmt"), finished);

  TrainOptions other_data = Options("parts", 30);
  other_data.resume = true;
  other_data.data_dir = dir_ / "val";
  EXPECT_NE(wm::test::ErrorText([&] { TrainMotion(other_data); }).find("other data"),
            std::string::npos);

  TrainOptions changed = Options("parts", 30);
  changed.resume = true;
  changed.config.model.flow_scale = 2;
  EXPECT_NE(wm::test::ErrorText([&] { TrainMotion(changed); }).find("model.flow_scale"),
            std::string::npos);
}

TEST(MotionConfigTest, ErrorsNameTheKey) {
  struct Case {
    const char* yaml;
    const char* named;
  };
  const Case cases[] = {
      {"model:\n  channels: 0\n", "model.channels"},
      {"model:\n  chanels: 4\n", "chanels"},
      {"model:\n  image_size: 36\n", "model.image_size"},
      {"model:\n  kind: sprites\n", "model.kind"},
      // the layered kind's motion CNN halves the frame four times
      {"model:\n  kind: layers\n  image_size: 40\n", "model.image_size"},
      {"model:\n  kind: pose\n  image_size: 40\n", "model.image_size"},
      {"model:\n  renderer_width: 6\n", "model.renderer_width"},
      {"train:\n  squared_until: 1.5\n", "train.squared_until"},
      {"train:\n  dynamics_batch: 0\n", "train.dynamics_batch"},
      {"train:\n  mask_noise_ramp: 2\n", "train.mask_noise_ramp"},
      {"train:\n  motion_prior_steps: 1.5\n", "train.motion_prior_steps"},
      {"train:\n  motion_prior: -1\n", "train.motion_prior"},
      {"train:\n  moved_weight: -0.5\n", "train.moved_weight"},
      {"train:\n  pair_window: -1\n", "train.pair_window"},
      {"train:\n  edge_weight: -1\n", "train.edge_weight"},
  };
  for (const Case& c : cases) {
    const std::string error = wm::test::ErrorText([&] { ParseMotionConfig(c.yaml, "m.yaml"); });
    EXPECT_NE(error.find(c.named), std::string::npos) << c.yaml << " -> " << error;
  }
}

// The pose kind's autoencoder pairs (train.pair_window): within the window when one is set,
// spread over the whole episode when not, and a pure function of (seed, step) either way.
TEST(WindowSamplerTest, PairsLieWithinTheWindow) {
  wm::test::TempDir dir;
  test::WriteMovingSquares(dir / "d", 8, 30, 3, "moving_square", false);
  const WindowSampler sampler(dir / "d", "image", 32, 1);
  int64_t widest_windowed = 0, widest_free = 0;
  for (int64_t step = 0; step < 50; ++step) {
    for (const PairRef& p : sampler.DrawPairs(7, step, 16, 3)) {
      ASSERT_GE(p.source, 0);
      ASSERT_LT(p.source, 30);
      widest_windowed = std::max(widest_windowed, std::abs(p.frame - p.source));
    }
    for (const PairRef& p : sampler.DrawPairs(7, step, 16))
      widest_free = std::max(widest_free, std::abs(p.frame - p.source));
  }
  EXPECT_EQ(widest_windowed, 3);  // reached, never passed
  EXPECT_GT(widest_free, 20);
  const std::vector<PairRef> a = sampler.DrawPairs(7, 4, 16, 3), b = sampler.DrawPairs(7, 4, 16, 3);
  for (size_t i = 0; i < a.size(); ++i)
    EXPECT_TRUE(a[i].episode == b[i].episode && a[i].frame == b[i].frame &&
                a[i].source == b[i].source);
}

// Why configs/motion/textured.yaml exists, small: on squares over a checkerboard the layered
// kind without the motion prior does not learn the motion in 300 steps (measured: 22.8 dB, below
// copying's 26.8, reversed actions no worse), with it it does (33.9 dB, reversing costs 7.5 dB).
TEST(MotionPriorTrainTest, OnATexturedBackgroundThePriorIsWhatMakesTheLayersMove) {
  wm::test::TempDir dir;
  test::WriteMovingSquares(dir / "train", 24, 12, 1, "moving_square", true);
  test::WriteMovingSquares(dir / "val", 6, 9, 99, "moving_square_val", true);
  const auto train = [&](double prior) {
    TrainOptions o;
    o.config = test::TestConfig();
    o.config.model.kind = "layers";
    o.config.train.motion_prior = prior;
    o.config.train.motion_prior_steps = 0.2;
    o.config.train.steps = 300;
    o.data_dir = dir / "train";
    o.val_dir = dir / "val";
    o.out_dir = dir / (prior > 0 ? "prior" : "none");
    o.show_progress = false;
    return *TrainMotion(o).val;
  };
  const auto without = train(0), with = train(1);
  EXPECT_GT(with.psnr, without.psnr + 3) << with.psnr << " vs " << without.psnr;
  EXPECT_GT(with.delta_tpsnr(), without.delta_tpsnr() + 3)
      << with.delta_tpsnr() << " vs " << without.delta_tpsnr();
}

// Issue 20's motion test, small: a model trained for 300 steps (seconds) imagines 6 frames from
// a val episode's first frame that (1) beat copying it by more than 1 dB, (2) are worse with the
// actions reversed by more than 1 dB (the actions, not a blur, carry the gain), and (3) on the
// pixels that really moved are closer to the true frame than to the first frame. The pose
// kind's autoencoder needs 1000 steps (measured: after 300 the pose does not yet say where the
// square is, and the frames do not follow the actions; after 1000, 31.0 dB vs copying's 27.5).
TEST_P(MotionTrainTest, LearnsMotionThatFollowsTheActions) {
  TrainOptions o = Options("learn", 300);
  if (GetParam() == "pose") o.config.train.steps = 1000;
  o.val_dir = dir_ / "val";
  const TrainSummary s = TrainMotion(o);
  ASSERT_TRUE(s.val.has_value());
  EXPECT_GT(s.val->psnr, s.val->copy_last_psnr + 1)
      << s.val->psnr << " vs " << s.val->copy_last_psnr;
  EXPECT_GT(s.val->delta_tpsnr(), 1) << s.val->psnr << " vs reversed " << s.val->reversed_psnr;

  const auto model = MotionModel::Load(dir_ / "learn");
  ASSERT_EQ(model->action_dim(), 7);
  const int S = 32, H = 6;
  const size_t frame = 3 * S * S;
  double to_truth = 0, to_first = 0;
  for (const EpisodeClip& clip : WindowSampler(dir_ / "val", "image", S, 1).Episodes(6, H + 1)) {
    const std::vector<float> first(clip.pixels.begin(), clip.pixels.begin() + frame);
    const std::vector<float> actions(clip.actions.begin(), clip.actions.begin() + H * 7);
    const std::vector<float> imagined = model->Imagine(first, actions, 1, H);
    for (int h = 0; h < H; ++h) {
      for (size_t i = 0; i < frame; ++i) {
        const float real = clip.pixels[(h + 1) * frame + i], start = first[i];
        if (std::abs(real - start) < 0.25f) continue;  // a pixel that moved (> 32 levels)
        to_truth += std::abs(imagined[h * frame + i] - real);
        to_first += std::abs(imagined[h * frame + i] - start);
      }
    }
  }
  EXPECT_LT(to_truth, to_first) << "on moved pixels the imagined frames stay nearer the start";
}

TEST_P(MotionTrainTest, ModelApiRejectsWrongActionWidth) {
  TrainMotion(Options("api", 5));
  const auto model = MotionModel::Load(dir_ / "api");
  EXPECT_TRUE(MotionModel::IsMotionCheckpoint(dir_ / "api"));
  const std::vector<float> first(3 * 32 * 32, 0.f), actions(2 * 5, 0.f);  // 5 values, not 7
  const std::string error = wm::test::ErrorText([&] { model->Imagine(first, actions, 1, 2); });
  EXPECT_NE(error.find("7 values per step"), std::string::npos) << error;
}

INSTANTIATE_TEST_SUITE_P(Kinds, MotionTrainTest,
                         ::testing::Values("warp", "layers", "textured_prior", "pose"),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace wm::motion

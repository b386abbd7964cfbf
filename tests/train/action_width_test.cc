// Actions of any width (issue 23): wm-train takes the token data's width, pads a mixture of
// widths to the widest with a per-dataset mask, records the width in the checkpoint only when it
// is not 7, and the public model API takes the action dataset's width.
#include <gtest/gtest.h>

#include <filesystem>

#include "core/atomic_file.h"
#include "tests/core/test_util.h"
#include "tests/train/moving_block.h"
#include "tests/train/test_config.h"
#include "train/dynamics_model.h"
#include "train/segment_sampler.h"
#include "train/trainer.h"

namespace wm::train {
namespace {
namespace fs = std::filesystem;
using wm::test::ErrorText;

class ActionWidthTest : public ::testing::Test {
 protected:
  void SetUp() override {
    test::WriteMovingBlockTokens(dir_ / "wide",
                                 {.dataset = "wide", .episodes = 4, .steps = 8, .action_dim = 14});
    test::WriteMovingBlockTokens(dir_ / "eef", {.episodes = 4, .steps = 8, .seed = 1});
    test::WriteMovingBlockTokens(dir_ / "g1",
                                 {.dataset = "g1", .episodes = 4, .steps = 8, .action_dim = 26});
  }
  TrainOptions Options(const std::string& run, std::vector<std::string> tokens) const {
    TrainOptions o{.config = test::TinyConfig(true), .out_dir = dir_ / run};
    for (const auto& t : tokens) o.token_dirs.push_back(dir_ / t);
    o.config.model.grid_h = o.config.model.grid_w = 4;
    o.config.model.num_codes = 32;
    o.config.train.batch_size = 2;
    o.config.train.steps = 3;
    o.config.train.warmup_steps = 1;
    o.config.train.checkpoint_every = 3;
    o.show_progress = false;
    return o;
  }
  nlohmann::json Manifest(const std::string& run) const {
    return nlohmann::json::parse(ReadFile(dir_ / (run + "/checkpoint.json")));
  }
  wm::test::TempDir dir_;
};

FrameContext Context(int64_t frames, int64_t action_dim) {
  FrameContext c{.batch = 1, .frames = frames};
  c.tokens.assign(static_cast<size_t>(frames * 16), 9);
  c.actions.assign(static_cast<size_t>(frames * action_dim), 0.02f);
  return c;
}

TEST_F(ActionWidthTest, TrainsAndPredictsAtTheDataWidth) {
  TrainDynamics(Options("g1", {"g1"}));
  EXPECT_EQ(Manifest("g1")["config"]["model"]["action_dim"], 26);
  auto model = DynamicsModel::Load(dir_ / "g1");
  EXPECT_EQ(model->action_dim(), 26);
  EXPECT_EQ(model->config().model.action_dim, 26);
  EXPECT_EQ(model->PredictNextFrame(Context(2, 26), 1).size(), 16u);
  const std::string err = ErrorText([&] { model->PredictNextFrame(Context(2, 7)); });
  EXPECT_NE(err.find("context has 7-dim actions, the model takes 26-dim ones"), std::string::npos)
      << err;
}

TEST_F(ActionWidthTest, SevenDimRunsStoreNoWidthAndLoadAsSeven) {
  TrainDynamics(Options("eef", {"eef"}));
  // The config of a 7-dim run has no model.action_dim: its bytes and hash stay those of runs
  // made before the key existed, and such (older) checkpoints load as 7.
  EXPECT_FALSE(Manifest("eef")["config"]["model"].contains("action_dim"));
  auto model = DynamicsModel::Load(dir_ / "eef");
  EXPECT_EQ(model->action_dim(), 7);
  EXPECT_EQ(model->PredictNextFrame(Context(2, 7), 1).size(), 16u);
}

TEST_F(ActionWidthTest, MixturePadsToTheWidestWithAMask) {
  SegmentSampler s({dir_ / "eef", dir_ / "wide"}, 4);
  ASSERT_EQ(s.action_dim(), 14);
  const auto refs = s.Draw(0, 0, 16);
  SegmentData d;
  s.Fill(refs, 0, refs.size(), d);
  ASSERT_EQ(d.action_mask.size(), refs.size() * 14);
  bool saw_both = false;
  for (size_t b = 0; b < refs.size(); ++b) {
    const int64_t real = refs[b].dataset == 0 ? 7 : 14;
    saw_both |= refs[b].dataset != refs[0].dataset;
    for (int64_t i = 0; i < 14; ++i) {
      EXPECT_EQ(d.action_mask[b * 14 + i], i < real ? 1.f : 0.f);
      for (int64_t t = 0; t < 4 && i >= real; ++t) EXPECT_EQ(d.actions[(b * 4 + t) * 14 + i], 0.f);
    }
  }
  EXPECT_TRUE(saw_both);
  // One width: no mask, the batch is what it was before widths could differ.
  SegmentData single;
  const SegmentSampler one({dir_ / "eef"}, 4);
  one.Fill(one.Draw(0, 0, 2), 0, 2, single);
  EXPECT_TRUE(single.action_mask.empty());
  EXPECT_NE(ErrorText([&] {
              SegmentSampler({dir_ / "wide"}, 4, "", 7);
            }).find("actions have 14 values, the model takes 7"),
            std::string::npos);
}

TEST_F(ActionWidthTest, MixtureTrainsAndEachDatasetKeepsItsWidth) {
  TrainDynamics(Options("mix", {"eef", "wide"}));
  const nlohmann::json m = Manifest("mix");
  EXPECT_EQ(m["config"]["model"]["action_dim"], 14);
  EXPECT_EQ(m["action_norms"]["moving_block"]["mean"].size(), 7u);
  EXPECT_EQ(m["action_norms"]["wide"]["mean"].size(), 14u);
  // The 7-dim dataset's raw actions go in as they are; the model pads them as in training.
  auto narrow = DynamicsModel::Load(dir_ / "mix", "cpu", "moving_block");
  EXPECT_EQ(narrow->action_dim(), 7);
  EXPECT_EQ(narrow->PredictNextFrame(Context(2, 7), 1).size(), 16u);
  EXPECT_EQ(DynamicsModel::Load(dir_ / "mix", "cpu", "wide")->action_dim(), 14);
}

TEST_F(ActionWidthTest, AnotherWidthRefusesResumeAndInitFrom) {
  TrainDynamics(Options("g1", {"g1"}));
  TrainOptions resume = Options("g1", {"eef"});
  resume.resume = true;
  std::string err = ErrorText([&] { TrainDynamics(resume); });
  EXPECT_NE(err.find("model.action_dim"), std::string::npos) << err;
  TrainOptions child = Options("child", {"eef"});
  child.init_from = dir_ / "g1";
  err = ErrorText([&] { TrainDynamics(child); });
  EXPECT_NE(err.find("the parent takes 26-dim actions, this token data has 7"), std::string::npos)
      << err;
}

}  // namespace
}  // namespace wm::train

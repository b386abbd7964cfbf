// wm-train --init-from / --freeze (train/init_from.h): the fine-tune starts from the parent's
// weights with a fresh optimizer, frozen parameters keep their bits, a killed fine-tune resumes
// byte-identically, shape errors name the key and both values, and checkpoint.json and the
// archive meta record the parent (by hash, never by path).
#include <gtest/gtest.h>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/provenance.h"
#include "core/sha256.h"
#include "core/tensor_archive.h"
#include "tests/core/test_util.h"
#include "tests/train/moving_block.h"
#include "tests/train/test_config.h"
#include "train/segment_sampler.h"
#include "train/trainer.h"

namespace wm::train {
namespace {

class DynamicsInitFromTest : public ::testing::Test {
 protected:
  void SetUp() override {
    test::WriteMovingBlockTokens(dir_ / "tokens", {.episodes = 8, .steps = 10, .seed = 1});
    TrainDynamics(Options("parent", 10));
  }
  TrainOptions Options(const std::string& run, int64_t steps) const {
    TrainOptions o{
        .config = test::TinyConfig(true), .token_dirs = {dir_ / "tokens"}, .out_dir = dir_ / run};
    o.config.model.grid_h = o.config.model.grid_w = 4;
    o.config.model.num_codes = 32;
    o.config.train.batch_size = 4;
    o.config.train.steps = steps;
    o.config.train.max_lr = 3e-3;
    o.config.train.warmup_steps = 3;
    o.config.train.checkpoint_every = 5;
    o.config.train.seed = 11;
    o.show_progress = false;
    return o;
  }
  TrainOptions FineTune(const std::string& run, int64_t steps) const {
    TrainOptions o = Options(run, steps);
    o.init_from = dir_ / "parent";
    o.config.train.seed = 5;  // a fine-tune may draw other batches than its parent
    return o;
  }
  std::string Hash(const std::string& run, const std::string& file) const {
    return Sha256Hex(ReadFile(dir_ / (run + "/" + file)));
  }
  nlohmann::json Manifest(const std::string& run) const {
    return nlohmann::json::parse(ReadFile(dir_ / (run + "/checkpoint.json")));
  }
  wm::test::TempDir dir_;
};

// With a learning rate of 1e-30 an AdamW step moves no weight by more than ~1e-30, so after the
// fine-tune's steps every weight is still the one it started from: the parent's, not a new init.
TEST_F(DynamicsInitFromTest, StartsFromTheParentsWeightsWithAFreshOptimizer) {
  auto still = [&](const std::string& run, bool init_from) {
    TrainOptions o = init_from ? FineTune(run, 2) : Options(run, 2);
    o.config.train.max_lr = 1e-30;
    o.config.train.min_lr = 0;
    return TrainDynamics(o);
  };
  EXPECT_EQ(still("ft", true).start_step, 0);
  still("fresh", false);
  const std::string parent = dir_ / "parent/checkpoint.wmt", ft = dir_ / "ft/checkpoint.wmt";
  EXPECT_LT(wm::test::MaxFloat32Difference(parent, ft, "model/"), 1e-20);
  // The check can tell the parent's weights from a new init's.
  EXPECT_GT(wm::test::MaxFloat32Difference(parent, dir_ / "fresh/checkpoint.wmt", "model/"), 1e-3);
  const nlohmann::json meta = TensorArchiveReader(ft).meta();
  EXPECT_EQ(meta.at("step"), 2);
  EXPECT_EQ(meta.at("adamw_step"), 2);  // not the parent's 10 + 2: moments start at zero
}

TEST_F(DynamicsInitFromTest, FrozenPolicyParametersStayBitIdentical) {
  TrainOptions o = FineTune("ft", 10);
  o.freeze = {"policy"};
  TrainDynamics(o);
  const std::string parent = dir_ / "parent/checkpoint.wmt", ft = dir_ / "ft/checkpoint.wmt";
  EXPECT_GT(wm::test::TensorNames(parent, "model/policy.").size(), 5u);
  EXPECT_EQ(wm::test::ChangedTensors(parent, ft, "model/policy."), std::vector<std::string>{});
  EXPECT_EQ(wm::test::TensorNames(ft, "adamw/exp_avg/policy.").size(), 0u);  // not optimised
  EXPECT_GT(wm::test::MaxFloat32Difference(parent, ft, "model/dynamics."),
            1e-4);  // the rest trained
}

TEST_F(DynamicsInitFromTest, KilledFineTuneResumesByteIdentically) {
  auto fine_tune = [&](const std::string& run) {
    TrainOptions o = FineTune(run, 20);
    o.freeze = {"policy"};
    return o;
  };
  TrainDynamics(fine_tune("full"));
  TrainOptions first = fine_tune("split");
  first.max_steps_this_run = 10;  // as if killed after the step-10 checkpoint
  TrainDynamics(first);
  TrainOptions rest = fine_tune("split");
  rest.resume = true;  // resuming wins over --init-from: it continues from step 10
  EXPECT_EQ(TrainDynamics(rest).start_step, 10);
  EXPECT_EQ(Hash("full", "checkpoint.wmt"), Hash("split", "checkpoint.wmt"));
  EXPECT_EQ(Hash("full", "checkpoint.json"), Hash("split", "checkpoint.json"));

  // Another parent, other frozen groups or no parent at all: the run's config hash differs.
  TrainDynamics(Options("other", 3));
  TrainOptions other = fine_tune("split");
  other.resume = true;
  other.init_from = dir_ / "other";
  EXPECT_NE(
      wm::test::ErrorText([&] { TrainDynamics(other); }).find("init_from.checkpoint_sha256: \""),
      std::string::npos);
  other = fine_tune("split");
  other.resume = true;
  other.freeze.clear();
  EXPECT_NE(wm::test::ErrorText([&] { TrainDynamics(other); }).find("init_from.freeze"),
            std::string::npos);
  TrainOptions plain = Options("split", 20);
  plain.resume = true;
  EXPECT_NE(
      wm::test::ErrorText([&] { TrainDynamics(plain); }).find("different config (init_from: {"),
      std::string::npos);
}

TEST_F(DynamicsInitFromTest, ShapeErrorsNameTheKeyAndBothValues) {
  const std::string given = dir_ / "parent";
  TrainOptions wide = FineTune("wide", 2);
  wide.config.model.d_model = 64;
  EXPECT_EQ(wm::test::ErrorText([&] { TrainDynamics(wide); }),
            "--init-from " + given + ": model.d_model is 32 in the parent, 64 here");
  TrainOptions classes = FineTune("classes", 2);
  classes.config.policy.classes = 8;
  EXPECT_EQ(wm::test::ErrorText([&] { TrainDynamics(classes); }),
            "--init-from " + given + ": policy.classes is 4 in the parent, 8 here");
  TrainOptions norm = FineTune("norm", 2);
  norm.config.model.norm = "rmsnorm";
  EXPECT_EQ(
      wm::test::ErrorText([&] { TrainDynamics(norm); }),
      "--init-from " + given + ": model.norm is \"layernorm\" in the parent, \"rmsnorm\" here");
  test::WriteMovingBlockTokens(dir_ / "stacked",
                               {.episodes = 4, .steps = 6, .seed = 2, .levels = 3});
  TrainOptions stacked = FineTune("stacked", 2);  // a residual tokenizer's codes, set by the data
  stacked.token_dirs = {dir_ / "stacked"};
  EXPECT_EQ(wm::test::ErrorText([&] { TrainDynamics(stacked); }),
            "--init-from " + given + ": model.levels is 1 in the parent, 3 here");
  TrainOptions no_parent = Options("none", 2);
  no_parent.freeze = {"policy"};
  EXPECT_NE(
      wm::test::ErrorText([&] { TrainDynamics(no_parent); }).find("--freeze needs --init-from"),
      std::string::npos);
  TrainOptions group = FineTune("group", 2);
  group.freeze = {"encoder"};
  EXPECT_EQ(wm::test::ErrorText([&] { TrainDynamics(group); }),
            "--freeze encoder: unknown parameter group (expected policy)");
  TrainOptions missing = FineTune("missing", 2);
  missing.init_from = dir_ / "nowhere";
  EXPECT_EQ(wm::test::ErrorText([&] { TrainDynamics(missing); }).rfind("--init-from ", 0), 0u);
}

TEST_F(DynamicsInitFromTest, ProvenanceRecordsTheParentByHash) {
  TrainDynamics(FineTune("ft", 2));
  const nlohmann::json parent = Manifest("parent"), ft = Manifest("ft");
  const nlohmann::json expected = {{"checkpoint_sha256", Hash("parent", "checkpoint.wmt")},
                                   {"config_hash", parent.at("config_hash")},
                                   {"step", 10},
                                   {"freeze", nlohmann::json::array()}};
  EXPECT_EQ(ft.at("init_from"), expected);
  nlohmann::json hashed = ft.at("config");
  hashed["init_from"] = expected;
  EXPECT_EQ(ft.at("config_hash"), ConfigHash(hashed));
  const TensorArchiveReader archive(dir_ / "ft/checkpoint.wmt");
  EXPECT_EQ(archive.meta().at("init_from"), expected);
  EXPECT_EQ(archive.meta().at("config_hash"), ft.at("config_hash"));
  EXPECT_EQ(ft.dump().find(dir_.path().string()), std::string::npos) << "no paths";
  EXPECT_FALSE(parent.contains("init_from"));  // a run from a random init has no such key
}

// The parent's action statistics stay for its datasets the fine-tune does not train on; the
// fine-tune's own data brings its own statistics.
TEST_F(DynamicsInitFromTest, KeepsTheParentsActionStatisticsForItsOtherDatasets) {
  test::WriteMovingBlockTokens(dir_ / "other", {.dataset = "other", .episodes = 4, .seed = 3});
  TrainOptions two = Options("two", 3);
  two.token_dirs.push_back(dir_ / "other");
  TrainDynamics(two);
  test::WriteMovingBlockTokens(dir_ / "new", {.episodes = 6, .steps = 10, .seed = 7});
  TrainOptions ft = FineTune("ft", 2);
  ft.init_from = dir_ / "two";
  ft.token_dirs = {dir_ / "new"};
  TrainDynamics(ft);
  const nlohmann::json norms = Manifest("ft").at("action_norms");
  EXPECT_EQ(norms.size(), 2u);
  EXPECT_EQ(norms.at("other"), Manifest("two").at("action_norms").at("other"));
  EXPECT_EQ(norms.at("moving_block"),
            SegmentSampler({dir_ / "new"}, 4).ActionNorms().at("moving_block"));
  EXPECT_NE(norms.at("moving_block"), Manifest("two").at("action_norms").at("moving_block"));
  EXPECT_EQ(TensorArchiveReader(dir_ / "ft/checkpoint.wmt").meta().at("action_norms"), norms);
}

}  // namespace
}  // namespace wm::train

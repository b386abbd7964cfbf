// wm-tokenize train --init-from / --freeze encoder (tokenize/init_from.h): the fine-tune starts
// from the parent's weights and codebook with a fresh optimizer, a frozen encoder and codebook
// keep their bits (so tokens stay identical), a killed fine-tune resumes byte-identically, shape
// errors name the key and both values, and the parent is recorded by hash.
#include <gtest/gtest.h>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/provenance.h"
#include "core/sha256.h"
#include "core/tensor_archive.h"
#include "tests/core/test_util.h"
#include "tests/tokenize/shapes_fixture.h"
#include "tokenize/trainer.h"

namespace wm::tokenize {
namespace {

class TokenizerInitFromTest : public ::testing::Test {
 protected:
  void SetUp() override {
    WriteShapesDataset(dir_ / "data");
    TrainTokenizer(Options("parent", 10));
  }
  TrainOptions Options(const std::string& run, int64_t steps) const {
    TrainOptions o{.config = TestConfig(), .data_dirs = {dir_ / "data"}, .out_dir = dir_ / run};
    o.config.train.steps = steps;
    o.show_progress = false;
    return o;
  }
  TrainOptions FineTune(const std::string& run, int64_t steps) const {
    TrainOptions o = Options(run, steps);
    o.init_from = dir_ / "parent";
    o.config.train.seed = 5;
    return o;
  }
  std::string Hash(const std::string& run, const std::string& file) const {
    return Sha256Hex(ReadFile(dir_ / (run + "/" + file)));
  }
  std::string Checkpoint(const std::string& run) const { return dir_ / (run + "/checkpoint.wmt"); }
  nlohmann::json Meta(const std::string& run) const {
    return TensorArchiveReader(Checkpoint(run)).meta();
  }
  test::TempDir dir_;
};

// With a learning rate of 1e-30 (and no dead-code re-seeding) no weight moves by more than
// ~1e-30: after the fine-tune's steps every weight, the codebook included, is still the parent's.
TEST_F(TokenizerInitFromTest, StartsFromTheParentsWeightsAndCodebook) {
  auto still = [&](const std::string& run, bool init_from) {
    TrainOptions o = init_from ? FineTune(run, 2) : Options(run, 2);
    o.config.train.max_lr = 1e-30;
    o.config.train.min_lr = 0;
    o.config.model.dead_code_steps = 0;
    return TrainTokenizer(o);
  };
  EXPECT_EQ(still("ft", true).start_step, 0);
  still("fresh", false);
  EXPECT_LT(test::MaxFloat32Difference(Checkpoint("parent"), Checkpoint("ft"), "model/"), 1e-20);
  EXPECT_GT(test::MaxFloat32Difference(Checkpoint("parent"), Checkpoint("fresh"), "model/"), 1e-3);
  EXPECT_EQ(Meta("ft").at("adamw_step"), 2);  // moments start at zero
}

TEST_F(TokenizerInitFromTest, FrozenEncoderAndCodebookStayBitIdentical) {
  TrainOptions o = FineTune("ft", 10);
  o.freeze = {"encoder"};
  TrainTokenizer(o);
  const std::string parent = Checkpoint("parent"), ft = Checkpoint("ft");
  EXPECT_GT(test::TensorNames(parent, "model/encoder.").size(), 3u);
  for (const char* frozen : {"model/encoder.", "model/quantizer.codebook"}) {
    EXPECT_EQ(test::ChangedTensors(parent, ft, frozen), std::vector<std::string>{}) << frozen;
  }
  for (const char* unoptimised : {"adamw/exp_avg/encoder.", "adamw/exp_avg/quantizer."}) {
    EXPECT_EQ(test::TensorNames(ft, unoptimised).size(), 0u) << unoptimised;
  }
  EXPECT_GT(test::MaxFloat32Difference(parent, ft, "model/decoder."), 1e-4);  // it trained
}

TEST_F(TokenizerInitFromTest, KilledFineTuneResumesByteIdentically) {
  auto fine_tune = [&](const std::string& run) {
    TrainOptions o = FineTune(run, 20);
    o.freeze = {"encoder"};
    return o;
  };
  TrainTokenizer(fine_tune("full"));
  TrainOptions first = fine_tune("split");
  first.max_steps_this_run = 10;  // as if killed after the step-10 checkpoint
  TrainTokenizer(first);
  TrainOptions rest = fine_tune("split");
  rest.resume = true;  // resuming wins over --init-from: it continues from step 10
  EXPECT_EQ(TrainTokenizer(rest).start_step, 10);
  EXPECT_EQ(Hash("full", "checkpoint.wmt"), Hash("split", "checkpoint.wmt"));
  EXPECT_EQ(Hash("full", "checkpoint.json"), Hash("split", "checkpoint.json"));
  TrainOptions other = fine_tune("split");
  other.resume = true;
  other.init_from = dir_ / "full";
  EXPECT_NE(test::ErrorText([&] { TrainTokenizer(other); }).find("init_from.checkpoint_sha256"),
            std::string::npos);
}

TEST_F(TokenizerInitFromTest, ShapeErrorsNameTheKeyAndBothValues) {
  const std::string given = dir_ / "parent";
  TrainOptions codes = FineTune("codes", 2);
  codes.config.model.num_codes = 128;
  EXPECT_EQ(test::ErrorText([&] { TrainTokenizer(codes); }),
            "--init-from " + given + ": model.num_codes is 64 in the parent, 128 here");
  TrainOptions grid = FineTune("grid", 2);
  grid.config.model.image_size = 64;
  EXPECT_EQ(test::ErrorText([&] { TrainTokenizer(grid); }),
            "--init-from " + given + ": model.image_size is 32 in the parent, 64 here");
  // A dynamics checkpoint has the same meta keys and a "model" tag the tokenizer's lacks.
  TensorArchiveWriter dynamics;
  dynamics.SetMeta({{"model", "wm-dynamics"}, {"config", {}}, {"config_hash", "c"}, {"step", 1}});
  dynamics.Write(dir_ / "dyn.wmt");
  TrainOptions wrong = FineTune("wrong", 2);
  wrong.init_from = dir_ / "dyn.wmt";
  EXPECT_NE(test::ErrorText([&] { TrainTokenizer(wrong); }).find("not a tokenizer checkpoint"),
            std::string::npos);
}

TEST_F(TokenizerInitFromTest, ProvenanceRecordsTheParentByHash) {
  TrainTokenizer(FineTune("ft", 2));
  const auto manifest = [&](const std::string& run) {
    return nlohmann::json::parse(ReadFile(dir_ / (run + "/checkpoint.json")));
  };
  const nlohmann::json parent = manifest("parent"), ft = manifest("ft");
  const nlohmann::json expected = {{"checkpoint_sha256", Hash("parent", "checkpoint.wmt")},
                                   {"config_hash", parent.at("config_hash")},
                                   {"step", 10},
                                   {"freeze", nlohmann::json::array()}};
  EXPECT_EQ(ft.at("init_from"), expected);
  nlohmann::json hashed = ft.at("config");
  hashed["init_from"] = expected;
  EXPECT_EQ(ft.at("config_hash"), ConfigHash(hashed));
  EXPECT_EQ(Meta("ft").at("init_from"), expected);
  EXPECT_EQ(Meta("ft").at("config_hash"), ft.at("config_hash"));
  EXPECT_EQ(ft.dump().find(dir_.path().string()), std::string::npos) << "no paths";
  EXPECT_FALSE(parent.contains("init_from"));
}

}  // namespace
}  // namespace wm::tokenize

// The training loop on a tiny synthetic shard dataset: loss goes down, runs are byte-for-byte
// reproducible, resume equals an uninterrupted run, and config errors name file and key.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/sha256.h"
#include "tests/core/test_util.h"
#include "tests/tokenize/shapes_fixture.h"
#include "tokenize/frame_sampler.h"
#include "tokenize/trainer.h"

namespace wm::tokenize {
namespace {
namespace fs = std::filesystem;

class TrainTest : public ::testing::Test {
 protected:
  void SetUp() override { WriteShapesDataset(data_dir()); }
  std::string data_dir() const { return dir_ / "data"; }
  TrainOptions Options(const std::string& run, int64_t steps) const {
    TrainOptions o{.config = TestConfig(), .data_dirs = {data_dir()}, .out_dir = dir_ / run};
    o.config.train.steps = steps;
    o.show_progress = false;
    return o;
  }
  // SHA-256 of a run's file (short failure messages; manifests hold long RNG states).
  std::string Read(const std::string& run, const std::string& file) const {
    const std::string bytes = ReadFile(dir_ / (run + "/" + file));
    if (const char* keep = std::getenv("WM_TOKENIZE_TEST_KEEP")) {
      fs::create_directories(fs::path(keep) / run);
      WriteFileAtomically((fs::path(keep) / run / file).string(), bytes);
    }
    return Sha256Hex(bytes);
  }
  test::TempDir dir_;
};

TEST_F(TrainTest, SamplerDrawsAreAPureFunctionOfSeedAndStep) {
  FrameSampler sampler({data_dir()}, "image", 32, 3);
  std::vector<float> batch(2 * 3 * 32 * 32);
  sampler.Load(sampler.BatchRefs(0, 2), batch.data());
  for (float v : batch) ASSERT_TRUE(v >= -1.f && v <= 1.f);
  auto key = [](const std::vector<FrameRef>& refs) {
    std::vector<size_t> k;
    for (const auto& r : refs) k.insert(k.end(), {r.dataset, r.episode, r.step});
    return k;
  };
  FrameSampler again({data_dir()}, "image", 32, 3);
  EXPECT_EQ(key(sampler.BatchRefs(7, 16)), key(again.BatchRefs(7, 16)));
  EXPECT_NE(key(sampler.BatchRefs(7, 16)), key(sampler.BatchRefs(8, 16)));
  for (const auto& r : sampler.BatchRefs(5, 64)) {
    EXPECT_LT(r.episode, 3u);
    EXPECT_LT(r.step, 6u);
  }
}

TEST_F(TrainTest, FramesAndAnchorsLoadedTogetherEqualEachLoadedAlone) {
  FrameSampler sampler({data_dir()}, "image", 32, 3);
  const std::vector<FrameRef> refs = sampler.BatchRefs(4, 12);
  const std::vector<AnchorRef> anchors = sampler.TrainingAnchors(refs, 4, 3, 0.5);
  const size_t floats = refs.size() * 3 * 32 * 32;
  std::vector<float> frames(floats), anchored(floats), together(2 * floats, 7.f);
  sampler.Load(refs, frames.data());
  sampler.Load(anchors, anchored.data());
  sampler.Load(refs, anchors, together.data(), together.data() + floats);
  EXPECT_EQ(std::vector<float>(together.begin(), together.begin() + floats), frames);
  EXPECT_EQ(std::vector<float>(together.begin() + floats, together.end()), anchored);
  int blank = 0, real = 0;
  for (size_t b = 0; b < anchors.size(); ++b) {
    const float* a = anchored.data() + b * 3 * 32 * 32;
    const bool zeros = std::all_of(a, a + 3 * 32 * 32, [](float v) { return v == 0.f; });
    EXPECT_EQ(zeros, anchors[b].blank) << "slot " << b;  // blank anchors are mid-grey zeros
    (anchors[b].blank ? blank : real)++;
  }
  EXPECT_GT(blank, 0);  // the draw covers both kinds
  EXPECT_GT(real, 0);
}

TEST_F(TrainTest, MixtureWeightsSetHowOftenEachDatasetIsDrawn) {
  const std::string second = dir_ / "second";
  WriteShapesDataset(second, "second");
  FrameSampler sampler({data_dir(), second}, "image", 32, 3, {1.0, 3.0});
  int from_second = 0;
  for (const auto& r : sampler.BatchRefs(0, 4000)) from_second += r.dataset == 1;
  EXPECT_NEAR(from_second / 4000.0, 0.75, 0.03);
}

TEST_F(TrainTest, LossDecreasesOverSixtySteps) {
  TrainSummary s = TrainTokenizer(Options("run", 60));
  EXPECT_EQ(s.end_step, 60);
  // The data-initialised codebook starts the loss low; 60 steps still cut it by > 30%.
  EXPECT_LT(s.last_loss, 0.7 * s.first_loss) << "first " << s.first_loss;
  EXPECT_TRUE(fs::exists(dir_ / "run/checkpoint.json"));
  const std::string csv = ReadFile(dir_ / "run/metrics.csv");
  EXPECT_EQ(csv.rfind("step,loss,recon_l1,", 0), 0u);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 1 + 12);  // header + every 5 steps
}

TEST_F(TrainTest, SameSeedGivesIdenticalCheckpointBytes) {
  TrainTokenizer(Options("a", 20));
  TrainTokenizer(Options("b", 20));
  EXPECT_EQ(Read("a", "checkpoint.wmt"), Read("b", "checkpoint.wmt"));
  EXPECT_EQ(Read("a", "checkpoint.json"), Read("b", "checkpoint.json"));
  TrainOptions other = Options("c", 20);
  other.config.train.seed = 12;
  TrainTokenizer(other);
  EXPECT_NE(Read("a", "checkpoint.wmt"), Read("c", "checkpoint.wmt"));
}

TEST_F(TrainTest, ResumeEqualsUninterruptedRun) {
  TrainTokenizer(Options("full", 20));
  TrainOptions first = Options("split", 20);
  first.max_steps_this_run = 10;  // as if killed after the step-10 checkpoint
  EXPECT_EQ(TrainTokenizer(first).end_step, 10);
  TrainOptions rest = Options("split", 20);
  rest.resume = true;
  TrainSummary s = TrainTokenizer(rest);
  EXPECT_EQ(s.start_step, 10);
  EXPECT_EQ(s.end_step, 20);
  EXPECT_EQ(Read("full", "checkpoint.wmt"), Read("split", "checkpoint.wmt"));
  EXPECT_EQ(Read("full", "checkpoint.json"), Read("split", "checkpoint.json"));
}

// A kill between the archive's rename and the manifest's leaves checkpoint.json describing the
// previous checkpoint; resuming from the final archive must still end with the right manifest.
TEST_F(TrainTest, ResumeRewritesAManifestLeftBehindByAKill) {
  TrainOptions first = Options("run", 10);
  first.max_steps_this_run = 5;
  TrainTokenizer(first);
  const std::string stale = ReadFile(dir_ / "run/checkpoint.json");
  TrainOptions rest = Options("run", 10);
  rest.resume = true;
  TrainTokenizer(rest);
  const std::string good = Read("run", "checkpoint.json");
  WriteFileAtomically(dir_ / "run/checkpoint.json", stale);
  EXPECT_EQ(TrainTokenizer(rest).end_step, 10);
  EXPECT_EQ(Read("run", "checkpoint.json"), good);
}

TEST_F(TrainTest, RefusesToOverwriteOrResumeWithAnotherConfig) {
  TrainTokenizer(Options("run", 5));
  EXPECT_NE(test::ErrorText([&] { TrainTokenizer(Options("run", 5)); }).find("--resume"),
            std::string::npos);
  TrainOptions changed = Options("run", 6);
  changed.resume = true;
  EXPECT_NE(test::ErrorText([&] {
              TrainTokenizer(changed);
            }).find("different config (train.steps: 5 -> 6)"),
            std::string::npos);
}

TEST(TokenizerConfig, PresetsLoad) {
  for (const char* name : {"tiny", "tiny16", "meta64", "whale-x", "stable64"}) {
    EXPECT_NO_THROW(LoadTokenizerConfig(test::SourceDir() + "/configs/tokenizer/" + name + ".yaml"))
        << name;
  }
  TokenizerConfig w = LoadTokenizerConfig(test::SourceDir() + "/configs/tokenizer/whale-x.yaml");
  EXPECT_EQ(w.model.num_codes, 2048);
  EXPECT_EQ(w.model.image_size / w.model.patch_size, 16);
  EXPECT_EQ(ConfigFromJson(ConfigToJson(w)).model.decoder_channels, 1024);
  TokenizerConfig t16 = LoadTokenizerConfig(test::SourceDir() + "/configs/tokenizer/tiny16.yaml");
  EXPECT_EQ(t16.model.image_size / t16.model.patch_size, 16);
  EXPECT_EQ(ConfigFromJson(ConfigToJson(t16)).model.detail_weight, 4.0);  // the key round-trips
  EXPECT_TRUE(t16.model.anchor_decoder);  // goal 1's recipe: 16x16 tokens decoded with an anchor
  TokenizerConfig tiny = LoadTokenizerConfig(test::SourceDir() + "/configs/tokenizer/tiny.yaml");
  TokenizerConfig back = ConfigFromJson(ConfigToJson(tiny));  // session 50's keys round-trip
  EXPECT_TRUE(back.model.anchor_flow);
  EXPECT_EQ(back.model.change_weight, 4.0);
  EXPECT_EQ(back.model.encoder, "conv");  // the default, and what checkpoints without the key get
  TokenizerConfig stable =
      LoadTokenizerConfig(test::SourceDir() + "/configs/tokenizer/stable64.yaml");
  EXPECT_EQ(ConfigFromJson(ConfigToJson(stable)).model.encoder, "cell_local");
  nlohmann::json old = ConfigToJson(stable);
  old["model"].erase("encoder");  // a checkpoint written before the key existed
  EXPECT_EQ(ConfigFromJson(old).model.encoder, "conv");
}

TEST(TokenizerConfig, ErrorsNameFileAndKey) {
  auto error = [](const std::string& yaml) {
    return test::ErrorText([&] { ParseTokenizerConfig(yaml, "cfg.yaml"); });
  };
  EXPECT_EQ(error("model:\n  patch_size: 3\n"),
            "cfg.yaml: key 'model.patch_size': must be a power of 2");
  EXPECT_NE(error("model:\n  latent_dim: many\n").find("cfg.yaml: key 'model.latent_dim'"),
            std::string::npos);
  EXPECT_NE(error("train:\n  stepz: 5\n").find("cfg.yaml: key 'train.stepz': unknown key"),
            std::string::npos);
  EXPECT_NE(error("optim: {}\n").find("key 'optim'"), std::string::npos);
  EXPECT_NE(error("model: [1\n").find("cfg.yaml"), std::string::npos);
  // The anchor's flow and the change weight act on an anchor: without the anchor decoder, none.
  EXPECT_EQ(error("model:\n  anchor_flow: true\n"),
            "cfg.yaml: key 'model.anchor_flow': needs model.anchor_decoder: true (it moves the "
            "anchor)");
  EXPECT_EQ(error("model:\n  change_weight: 2\n"),
            "cfg.yaml: key 'model.change_weight': needs model.anchor_decoder: true (change is "
            "measured against the anchor)");
  EXPECT_EQ(error("model:\n  encoder: local\n"),
            "cfg.yaml: key 'model.encoder': must be conv or cell_local");
  EXPECT_EQ(error("model:\n  anchor_decoder: true\n  change_weight: -1\n"),
            "cfg.yaml: key 'model.change_weight': must be >= 0");
}

}  // namespace
}  // namespace wm::tokenize

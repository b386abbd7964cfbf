// The training loop on a tiny synthetic shard dataset: loss goes down, runs are byte-for-byte
// reproducible, resume equals an uninterrupted run, and config errors name file and key.
#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/sha256.h"
#include "core/shard/dataset_writer.h"
#include "tests/core/test_util.h"
#include "tokenize/frame_sampler.h"
#include "tokenize/trainer.h"

namespace wm::tokenize {
namespace {
namespace fs = std::filesystem;

// A 48x48 PNG: a coloured background with a rectangle and a circle that move with `t`.
std::string ShapeFrame(int episode, int t) {
  cv::Mat img(48, 48, CV_8UC3, cv::Scalar(40 + 30 * episode, 90, 160 - 20 * episode));
  cv::rectangle(img, cv::Rect(4 + 3 * t, 6, 14, 10), cv::Scalar(20, 220, 240), cv::FILLED);
  cv::circle(img, cv::Point(30, 14 + 3 * t), 7, cv::Scalar(230, 40, 60 * episode), cv::FILLED);
  std::vector<uchar> png;
  cv::imencode(".png", img, png);
  return std::string(png.begin(), png.end());
}

// 3 episodes x 6 steps of PNG frames.
void WriteShapesDataset(const std::string& dir) {
  shard::DatasetWriter writer({.dir = dir, .config_hash = "tokenize-test"});
  for (int e = 0; e < 3; ++e) {
    Episode ep = test::MakeEpisode(6, e, "shapes" + std::to_string(e));
    EncodedFrames& f = ep.images["image"];
    f.encoding = "png";
    f.height = f.width = 48;
    f.channels = 3;
    f.frames.clear();
    for (int t = 0; t < 6; ++t) f.frames.push_back(ShapeFrame(e, t));
    writer.Add(ep, e);
  }
  shard::DatasetIndex meta;
  meta.dataset = "shapes";
  meta.split = "train";
  writer.Finish(meta);
}

TokenizerConfig TestConfig() {
  TokenizerConfig c;
  c.model = {.image_size = 32,
             .patch_size = 4,
             .encoder_channels = 16,
             .encoder_layers = 1,
             .decoder_channels = 16,
             .decoder_layers = 1,
             .latent_dim = 8,
             .num_codes = 64,
             .l2_normalize = true,
             .beta = 0.25,
             .dead_code_steps = 5};
  c.train.batch_size = 4;
  c.train.steps = 30;
  c.train.max_lr = 3e-3;
  c.train.min_lr = 3e-4;
  c.train.warmup_steps = 3;
  c.train.threads = 1;
  c.train.checkpoint_every = 10;
  c.train.log_every = 5;
  c.train.seed = 11;
  return c;
}

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

TEST_F(TrainTest, SamplerDecodesFramesToMinusOneOne) {
  FrameSampler sampler({data_dir()}, "image", 32, 3);
  std::vector<float> batch;
  sampler.NextBatch(2, batch);
  ASSERT_EQ(batch.size(), 2u * 3 * 32 * 32);
  for (float v : batch) ASSERT_TRUE(v >= -1.f && v <= 1.f);
  const std::string state = sampler.rng_state();
  std::vector<float> a, b;
  sampler.NextBatch(2, a);
  sampler.set_rng_state(state);
  sampler.NextBatch(2, b);
  EXPECT_EQ(a, b);
}

TEST_F(TrainTest, LossDecreasesOverThirtySteps) {
  TrainSummary s = TrainTokenizer(Options("run", 30));
  EXPECT_EQ(s.end_step, 30);
  EXPECT_LT(s.last_loss, 0.7 * s.first_loss) << "first " << s.first_loss;
  EXPECT_TRUE(fs::exists(dir_ / "run/checkpoint.json"));
  const std::string csv = ReadFile(dir_ / "run/metrics.csv");
  EXPECT_EQ(csv.rfind("step,loss,recon_l1,", 0), 0u);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 1 + 6);  // header + every 5 steps
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

TEST_F(TrainTest, RefusesToOverwriteOrResumeWithAnotherConfig) {
  TrainTokenizer(Options("run", 5));
  EXPECT_NE(test::ErrorText([&] { TrainTokenizer(Options("run", 5)); }).find("--resume"),
            std::string::npos);
  TrainOptions changed = Options("run", 6);
  changed.resume = true;
  EXPECT_NE(test::ErrorText([&] { TrainTokenizer(changed); }).find("different config"),
            std::string::npos);
}

TEST(TokenizerConfig, PresetsLoad) {
  for (const char* name : {"tiny", "meta64", "whale-x"}) {
    EXPECT_NO_THROW(LoadTokenizerConfig(test::SourceDir() + "/configs/tokenizer/" + name + ".yaml"))
        << name;
  }
  TokenizerConfig w = LoadTokenizerConfig(test::SourceDir() + "/configs/tokenizer/whale-x.yaml");
  EXPECT_EQ(w.model.num_codes, 2048);
  EXPECT_EQ(w.model.image_size / w.model.patch_size, 16);
  EXPECT_EQ(ConfigFromJson(ConfigToJson(w)).model.decoder_channels, 1024);
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
}

TEST(LearningRate, WarmsUpThenFollowsCosineToMinimum) {
  TrainConfig t;
  t.max_lr = 1.0;
  t.min_lr = 0.1;
  t.warmup_steps = 10;
  t.steps = 110;
  EXPECT_DOUBLE_EQ(LearningRateAt(t, 0), 0.1);
  EXPECT_DOUBLE_EQ(LearningRateAt(t, 9), 1.0);
  EXPECT_DOUBLE_EQ(LearningRateAt(t, 10), 1.0);
  EXPECT_NEAR(LearningRateAt(t, 60), 0.55, 1e-12);
  EXPECT_NEAR(LearningRateAt(t, 110), 0.1, 1e-12);
}

}  // namespace
}  // namespace wm::tokenize

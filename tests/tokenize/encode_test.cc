// Pre-tokenizing and decoding: a trained tokenizer's codes survive the token dataset exactly,
// sharded encoding equals one job, decode writes what it says, and the tiny model can overfit
// a handful of frames to a high PSNR.
#include "tokenize/encode.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "core/atomic_file.h"
#include "core/image_codec.h"
#include "core/shard/dataset_reader.h"
#include "core/tokens/token_dataset.h"
#include "tests/core/test_util.h"
#include "tests/tokenize/shapes_fixture.h"
#include "tokenize/decode.h"
#include "tokenize/frame_sampler.h"
#include "tokenize/tokenizer.h"
#include "tokenize/trainer.h"

namespace wm::tokenize {
namespace {
namespace fs = std::filesystem;

class EncodeTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir();
    WriteShapesDataset(data());
    TrainOptions o{.config = TestConfig(), .data_dirs = {data()}, .out_dir = run()};
    o.config.train.steps = 10;
    o.show_progress = false;
    TrainTokenizer(o);
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string data() { return *dir_ / "data"; }
  static std::string run() { return *dir_ / "run"; }
  static EncodeSummary Encode(const std::string& out, int part = 0, int parts = 1) {
    return EncodeDataset({.checkpoint = run(),
                          .data_dir = data(),
                          .out_dir = out,
                          .shard_index = part,
                          .num_shards = parts,
                          .show_progress = false});
  }
  static std::vector<int64_t> AllTokens(const tokens::TokenDataset& d) {
    std::vector<int64_t> all;
    for (int64_t k = 0; k < d.num_episodes(); ++k) {
      std::vector<int64_t> t(static_cast<size_t>(d.episode(k).num_frames * d.tokens_per_frame()));
      d.CopyTokens(k, 0, d.episode(k).num_frames, t.data());
      all.insert(all.end(), t.begin(), t.end());
    }
    return all;
  }
  static test::TempDir* dir_;
};
test::TempDir* EncodeTest::dir_ = nullptr;

TEST_F(EncodeTest, TokenDatasetHoldsExactlyTheInMemoryCodes) {
  const std::string out = *dir_ / "tokens";
  EncodeSummary s = Encode(out);
  EXPECT_TRUE(s.index_written);
  EXPECT_EQ(s.episodes, 3);
  EXPECT_EQ(s.frames, 18);
  tokens::TokenDataset d(out);
  Tokenizer tok(run());
  EXPECT_EQ(d.index().tokenizer.checkpoint_sha256, tok.checkpoint_sha256());
  EXPECT_EQ(d.tokens_per_frame(), 64);
  shard::DatasetReader source(data());
  for (int64_t k = 0; k < 3; ++k) {
    Episode e = source.ReadEpisode(k);
    std::vector<float> frames(6 * 3 * 32 * 32);
    for (int t = 0; t < 6; ++t) DecodeFrame(e.images["image"].frames[t], 32, &frames[t * 3072]);
    std::vector<uint32_t> codes = tok.Encode(frames.data(), 6);
    std::vector<int64_t> stored(codes.size());
    d.CopyTokens(k, 0, 6, stored.data());
    ASSERT_TRUE(std::equal(codes.begin(), codes.end(), stored.begin())) << "episode " << k;
    std::vector<uint32_t> narrowed(stored.begin(), stored.end());
    EXPECT_EQ(tok.Decode(narrowed.data(), 6), tok.Decode(codes.data(), 6));
    for (int i = 0; i < 6 * 7; ++i) EXPECT_EQ(d.actions(k)[i], e.actions[i]);
    EXPECT_EQ(d.episode(k).episode_key, e.episode_key);
  }
  EXPECT_TRUE(Encode(out).skipped);  // a rerun keeps the finished part
}

TEST_F(EncodeTest, ThreeShardJobsEqualOneJob) {
  const std::string one = *dir_ / "one", three = *dir_ / "three";
  Encode(one);
  EXPECT_FALSE(Encode(three, 2, 3).index_written);
  EXPECT_FALSE(Encode(three, 0, 3).index_written);
  EXPECT_TRUE(Encode(three, 1, 3).index_written);
  tokens::TokenDataset a(one), b(three);
  EXPECT_EQ(b.index().num_parts, 3);
  EXPECT_EQ(AllTokens(a), AllTokens(b));
  EXPECT_EQ(a.index().provenance, b.index().provenance);
}

#ifndef WM_HAVE_OPENCV
TEST_F(EncodeTest, DecodeSaysItNeedsOpenCv) {
  const std::string out = *dir_ / "tokens-decode";
  Encode(out);
  EXPECT_NE(test::ErrorText([&] {
              DecodeEpisode({.checkpoint = run(), .tokens_dir = out, .out = *dir_ / "x.png"});
            }).find("needs OpenCV"),
            std::string::npos);
}
#else
TEST_F(EncodeTest, DecodeWritesContactSheetAndRefusesOtherTokenizers) {
  const std::string out = *dir_ / "tokens-decode";
  Encode(out);
  const std::string png = *dir_ / "sheet.png";
  EXPECT_EQ(DecodeEpisode({.checkpoint = run(),
                           .tokens_dir = out,
                           .episode = 1,
                           .out = png,
                           .originals_dir = data(),
                           .columns = 4}),
            6);
  const DecodedImage sheet = DecodePngOrJpeg(ReadFile(png), png);
  EXPECT_EQ(sheet.width, 4 * 32);
  EXPECT_EQ(sheet.height, 2 * 2 * 32);  // 2 rows of frames, each original above decoded
  DecodeEpisode({.checkpoint = run(), .tokens_dir = out, .out = *dir_ / "frames"});
  EXPECT_TRUE(fs::exists(fs::path(*dir_ / "frames") / "frame_0005.png"));
  TrainOptions other{.config = TestConfig(), .data_dirs = {data()}, .out_dir = *dir_ / "other"};
  other.config.train.steps = 2;
  other.show_progress = false;
  TrainTokenizer(other);
  EXPECT_NE(test::ErrorText([&] {
              DecodeEpisode({.checkpoint = *dir_ / "other", .tokens_dir = out, .out = png});
            }).find("written by another tokenizer"),
            std::string::npos);
}

#endif

TEST(Overfit, TinyTokenizerReconstructsAHandfulOfFrames) {
  test::TempDir dir;
  WriteShapesDataset(dir / "data");
  TrainOptions o{.config = TestConfig(), .data_dirs = {dir / "data"}, .out_dir = dir / "run"};
  // Width at the token grid matters most here: 64 channels there, 16 at full resolution.
  o.config.model.encoder_channels = o.config.model.decoder_channels = 64;
  o.config.model.min_channels = 16;
  o.config.train.steps = 800;
  o.config.train.max_lr = 2e-3;
  o.config.train.checkpoint_every = o.config.train.steps;
  o.config.train.val_frames = 18;
  o.val_dirs = {dir / "data"};
  o.show_progress = false;
  TrainSummary s = TrainTokenizer(o);
  ASSERT_TRUE(s.val.has_value());
  // Measured 34.2 dB / 0.959 (CPU, 1 thread); a broken quantiser or decoder stays below 25 dB.
  EXPECT_GT(s.val->psnr, 30.0);
  EXPECT_GT(s.val->ssim, 0.93);
}

}  // namespace
}  // namespace wm::tokenize

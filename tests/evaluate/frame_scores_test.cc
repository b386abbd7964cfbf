// wm-eval's per-frame scores: MS-SSIM appears exactly when the frames are large enough for its
// five scales, and is the metrics library's value on the same uint8 frames.
#include "evaluate/frame_scores.h"

#include <gtest/gtest.h>

#include <cmath>

#include "metrics/image.h"
#include "metrics/pixel_metrics.h"
#include "tests/core/test_util.h"
#include "tests/tokenize/shapes_fixture.h"
#include "tokenize/tokenizer.h"
#include "tokenize/trainer.h"

namespace wm::evaluate {
namespace {

// A tokenizer for `size`-pixel frames after one training step: ScoreFrames needs one for
// lpips_style, its quality does not matter here.
std::string TrainTokenizer(const test::TempDir& dir, int size) {
  const std::string data = dir / "data", run = dir / ("tok" + std::to_string(size));
  if (!std::filesystem::exists(data)) tokenize::WriteShapesDataset(data);
  tokenize::TrainOptions o{.config = tokenize::TestConfig(), .data_dirs = {data}, .out_dir = run};
  o.config.model.image_size = size;
  o.config.train.steps = 1;
  o.show_progress = false;
  tokenize::TrainTokenizer(o);
  return run;
}

// Two frames of smooth colour gradients with a moving bright square, in [-1, 1].
Clip Gradients(int size, int shift) {
  Clip c{.frames = 2, .size = size, .pixels = {}};
  for (int t = 0; t < 2; ++t) {
    for (int ch = 0; ch < 3; ++ch) {
      for (int y = 0; y < size; ++y) {
        for (int x = 0; x < size; ++x) {
          const bool square = std::abs(x - size / 3 - shift * (t + 1)) < size / 8 &&
                              std::abs(y - size / 2) < size / 8;
          c.pixels.push_back(square ? 0.9f
                                    : static_cast<float>(std::sin(0.05 * (x + 2 * y) + ch) * 0.6));
        }
      }
    }
  }
  return c;
}

metrics::Image Uint8Frame(const Clip& c, int t) {
  const std::vector<uint8_t> rgb = tokenize::PlanarToRgb8(c.frame(t), c.size);
  return metrics::Image::FromUint8(rgb.data(), c.size, c.size, 3);
}

TEST(FrameScores, MsSsimIsScoredExactlyWhereFramesHaveRoomForFiveScales) {
  test::TempDir dir;
  const int large = 192;  // >= metrics::kMsSsimMinSide (176)
  ASSERT_GE(large, metrics::kMsSsimMinSide);
  {
    tokenize::Tokenizer tok(TrainTokenizer(dir, large));
    const Clip real = Gradients(large, 0), pred = Gradients(large, 6);
    const auto scores = ScoreFrames(real, pred, tok);
    ASSERT_EQ(scores.count("ms_ssim"), 1u);
    ASSERT_EQ(scores.at("ms_ssim").size(), 2u);
    for (int t = 0; t < 2; ++t) {
      const double expected = metrics::MsSsim(Uint8Frame(real, t), Uint8Frame(pred, t));
      EXPECT_EQ(scores.at("ms_ssim")[t], expected) << "frame " << t;
      EXPECT_GT(expected, 0.3);
      EXPECT_LT(expected, 0.999);  // the square moved
    }
    EXPECT_EQ(ScoreFrames(real, real, tok).at("ms_ssim"), (std::vector<double>{1.0, 1.0}));
  }
  tokenize::Tokenizer small_tok(TrainTokenizer(dir, 64));
  const auto scores = ScoreFrames(Gradients(64, 0), Gradients(64, 2), small_tok);
  EXPECT_EQ(scores.count("ms_ssim"), 0u);
  for (const char* metric : {"mse", "psnr", "ssim", "lpips_style"}) {
    EXPECT_EQ(scores.count(metric), 1u) << metric;
  }
}

}  // namespace
}  // namespace wm::evaluate

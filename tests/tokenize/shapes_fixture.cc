#include "tests/tokenize/shapes_fixture.h"

#include <array>

#include "core/image_codec.h"
#include "core/shard/dataset_writer.h"
#include "tests/core/test_util.h"

namespace wm::tokenize {

// A 48x48 PNG: a coloured background with a rectangle and a disc that move with `t`. Drawn by
// hand and encoded with core/image_codec.h, so builds without OpenCV (WM_MODEL_ONLY) have it.
std::string ShapeFrame(int episode, int t) {
  constexpr int kSize = 48;
  std::vector<uint8_t> rgb(kSize * kSize * 3);
  auto paint = [&](int x, int y, std::array<int, 3> colour) {
    for (int c = 0; c < 3; ++c) rgb[(y * kSize + x) * 3 + c] = static_cast<uint8_t>(colour[c]);
  };
  const int rect_x = 4 + 3 * t, disc_y = 14 + 3 * t;
  for (int y = 0; y < kSize; ++y) {
    for (int x = 0; x < kSize; ++x) {
      paint(x, y, {160 - 20 * episode, 90, 40 + 30 * episode});
      if (x >= rect_x && x < rect_x + 14 && y >= 6 && y < 16) paint(x, y, {240, 220, 20});
      if ((x - 30) * (x - 30) + (y - disc_y) * (y - disc_y) <= 49)
        paint(x, y, {60 * episode, 40, 230});
    }
  }
  return EncodePng(rgb.data(), kSize, kSize, 3);
}

void WriteShapesDataset(const std::string& dir, const std::string& name) {
  shard::DatasetWriter writer({.dir = dir, .config_hash = "tokenize-test"});
  for (int e = 0; e < 3; ++e) {
    Episode ep = test::MakeEpisode(6, e, "shapes" + std::to_string(e));
    std::vector<std::string> frames;
    for (int t = 0; t < 6; ++t) frames.push_back(ShapeFrame(e, t));
    test::SetPngFrames(ep, std::move(frames), 48);
    writer.Add(ep, e);
  }
  test::FinishTrainSplit(writer, name);
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

}  // namespace wm::tokenize

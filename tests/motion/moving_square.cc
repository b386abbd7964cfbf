#include "tests/motion/moving_square.h"

#include <array>
#include <random>

#include "core/image_codec.h"
#include "core/shard/dataset_writer.h"
#include "tests/core/test_util.h"

namespace wm::motion::test {
namespace {

constexpr int kSize = 32, kSquare = 6, kPixelsPerUnit = 3;

std::string Frame(int x, int y, bool textured) {
  std::vector<uint8_t> rgb(kSize * kSize * 3);
  for (int v = 0; v < kSize; ++v) {
    for (int u = 0; u < kSize; ++u) {
      const bool dark = textured && (u / 4 + v / 4) % 2;
      std::array<int, 3> colour =
          dark ? std::array<int, 3>{70, 60, 45} : std::array<int, 3>{120, 100, 80};
      if ((u - 24) * (u - 24) + (v - 7) * (v - 7) <= 12) colour = {40, 60, 200};
      if (u >= x && u < x + kSquare && v >= y && v < y + kSquare) colour = {220, 30, 30};
      for (int c = 0; c < 3; ++c) rgb[(v * kSize + u) * 3 + c] = static_cast<uint8_t>(colour[c]);
    }
  }
  return EncodePng(rgb.data(), kSize, kSize, 3);
}

// -1 or +1 at random, the sign that stays inside the frame when the other would not.
int Step(int position, std::mt19937_64& rng) {
  const int step = rng() % 2 ? 1 : -1;
  const int next = position + kPixelsPerUnit * step;
  return next < 0 || next > kSize - kSquare ? -step : step;
}

}  // namespace

void WriteMovingSquares(const std::string& dir, int episodes, int steps, uint64_t seed,
                        const std::string& name, bool textured) {
  shard::DatasetWriter writer({.dir = dir, .config_hash = "motion-test"});
  std::mt19937_64 rng(seed);
  for (int e = 0; e < episodes; ++e) {
    Episode ep = wm::test::MakeEpisode(steps, seed + e, name + std::to_string(e));
    std::vector<std::string> frames;
    int x = 4 + static_cast<int>(rng() % 20), y = 12 + static_cast<int>(rng() % 12);
    for (int t = 0; t < steps; ++t) {
      frames.push_back(Frame(x, y, textured));
      // Every step moves (no two equal frames): +-1 per axis, turned back at the borders.
      const int dx = Step(x, rng), dy = Step(y, rng);
      std::fill(ep.actions.begin() + t * kActionDim, ep.actions.begin() + (t + 1) * kActionDim, 0);
      ep.actions[t * kActionDim] = static_cast<float>(dx);
      ep.actions[t * kActionDim + 1] = static_cast<float>(dy);
      x += kPixelsPerUnit * dx;
      y += kPixelsPerUnit * dy;
    }
    wm::test::SetPngFrames(ep, std::move(frames), kSize);
    writer.Add(ep, e);
  }
  wm::test::FinishTrainSplit(writer, name);
}

MotionConfig TestConfig() {
  MotionConfig c;
  c.model.image_size = 32;
  c.model.channels = 16;
  c.train.batch_size = 8;
  c.train.steps = 40;
  c.train.warmup_steps = 5;
  c.train.checkpoint_every = 10;
  c.train.log_every = 5;
  c.train.seed = 5;
  c.train.val_episodes = 4;
  c.train.val_horizon = 6;
  return c;
}

}  // namespace wm::motion::test

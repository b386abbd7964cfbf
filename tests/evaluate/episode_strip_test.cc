// The strip overview stacks episodes of different lengths: episodes shorter than the horizon
// have narrower strips (the ablation's 24-step rollouts met this: vconcat refused the rows).
#include "evaluate/episode_strip.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "tests/core/test_util.h"

namespace wm::evaluate {
namespace {

constexpr int kSize = 32;

Clip GreyClip(int64_t frames, float level) {
  return {.frames = frames,
          .size = kSize,
          .pixels = std::vector<float>(frames * 3 * kSize * kSize, level)};
}

int StripWidth(int columns) {
  const int cell = kSize * StripScale(kSize);
  return kStripLabelWidth + columns * cell + (columns - 1) * kStripGap;
}

TEST(StripOverview, EpisodesShorterThanTheHorizonArePaddedToTheWidestStrip) {
  const test::TempDir tmp;
  const std::string dir = tmp.path().string();
  // Episode 3 has 2 imagined steps, episode 7 has 5: strips of 3 and 6 columns.
  WriteEpisodeStrip(dir, 3, GreyClip(3, 0.2f), {{"plain", GreyClip(2, -0.2f)}});
  WriteEpisodeStrip(dir, 7, GreyClip(6, 0.2f), {{"plain", GreyClip(5, -0.2f)}});
  ASSERT_EQ(cv::imread(dir + "/episode_3.png").cols, StripWidth(3));
  ASSERT_EQ(cv::imread(dir + "/episode_7.png").cols, StripWidth(6));

  WriteStripOverview(dir, {3, 7}, 2, kSize);

  const cv::Mat overview = cv::imread(dir + "/overview.png");
  ASSERT_FALSE(overview.empty());
  EXPECT_EQ(overview.cols, StripWidth(6));
  // Header, then per episode its real and plain rows with their gaps, the error row (the strip's
  // last, no gap below it) and a 3-gap separator.
  const int cell = kSize * StripScale(kSize);
  EXPECT_EQ(overview.rows, kStripHeaderHeight + 2 * (3 * cell + 2 * kStripGap + 3 * kStripGap));
}

}  // namespace
}  // namespace wm::evaluate

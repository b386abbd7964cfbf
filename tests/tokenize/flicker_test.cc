// Token flicker (issue 20): CountFlicker against a count made by hand, and the trainer's val.csv
// columns that report it.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "tests/core/test_util.h"
#include "tests/tokenize/shapes_fixture.h"
#include "tokenize/trainer.h"
#include "tokenize/validation.h"

namespace wm::tokenize {
namespace {

constexpr int kSize = 8, kGrid = 2;  // 2x2 cells of 4x4 pixels

// Sets channel c of pixel (y, x) of frame t in an interleaved [T, 8, 8, 3] buffer.
void Set(std::vector<uint8_t>& rgb, int t, int y, int x, int c, int value) {
  rgb[((static_cast<size_t>(t) * kSize + y) * kSize + x) * 3 + c] = static_cast<uint8_t>(value);
}

TEST(Flicker, MatchesAHandCount) {
  // Three frames of a grey image; cells numbered 0 1 / 2 3 (row-major).
  std::vector<uint8_t> rgb(3 * kSize * kSize * 3, 100);
  Set(rgb, 1, 0, 7, 2, 140);  // frame 1: cell 1 has a pixel 40 levels off (blue): moved
  for (int t = 1; t < 3; ++t) Set(rgb, t, 7, 7, 0, 130);  // cell 3: exactly 30 levels: static
  Set(rgb, 2, 3, 3, 1, 69);   // frame 2: cell 0, 31 levels down from frame 1 (green): moved
  Set(rgb, 2, 5, 0, 0, 200);  // frame 2: cell 2 moved, but its token stays: not a change
  const std::vector<int64_t> codes = {1, 2, 3, 4,   // frame 0
                                      1, 5, 3, 6,   // frame 1: cells 1 (moved), 3 (static)
                                      7, 5, 3, 6};  // frame 2: cell 0 (moved)
  const FlickerCounts n = CountFlicker(codes.data(), rgb.data(), 3, kSize, kGrid);
  EXPECT_EQ(n.cells, 8);           // 2 frame pairs x 4 cells
  EXPECT_EQ(n.changes, 3);         // cell 1 and 3 at t = 1, cell 0 at t = 2
  EXPECT_EQ(n.static_changes, 1);  // cell 3: its largest pixel change is 30, not above
  EXPECT_DOUBLE_EQ(n.flicker(), 1.0 / 3.0);
  EXPECT_DOUBLE_EQ(n.change_rate(), 3.0 / 8.0);

  FlickerCounts sum = n;
  sum += n;
  EXPECT_EQ(sum.changes, 6);
  EXPECT_DOUBLE_EQ(sum.flicker(), 1.0 / 3.0);
}

TEST(Flicker, NoChangeIsNoFlicker) {
  const std::vector<uint8_t> rgb(2 * kSize * kSize * 3, 50);
  const std::vector<int64_t> codes(2 * kGrid * kGrid, 9);
  const FlickerCounts n = CountFlicker(codes.data(), rgb.data(), 2, kSize, kGrid);
  EXPECT_EQ(n.cells, 4);
  EXPECT_EQ(n.flicker(), 0.0);
  EXPECT_EQ(n.change_rate(), 0.0);
  EXPECT_EQ(CountFlicker(codes.data(), rgb.data(), 1, kSize, kGrid).cells, 0);  // no pair
}

TEST(Flicker, ValCsvReportsItEveryValidation) {
  test::TempDir dir;
  WriteShapesDataset(dir / "data");
  TrainOptions o{.config = TestConfig(), .data_dirs = {dir / "data"}, .out_dir = dir / "run"};
  o.config.train.steps = 4;
  o.config.train.val_every = 2;
  o.config.train.val_frames = 8;
  o.val_dirs = {dir / "data"};
  o.show_progress = false;
  const TrainSummary s = TrainTokenizer(o);
  ASSERT_TRUE(s.val.has_value());
  std::ifstream in(dir / "run/val.csv");
  std::string header, row, last;
  std::getline(in, header);
  EXPECT_EQ(header, "step,psnr,ssim,recon_l1,flicker,token_change_rate");
  int rows = 0;
  while (std::getline(in, row)) {
    last = row;
    ++rows;
  }
  EXPECT_EQ(rows, 2);  // steps 2 and 4
  std::vector<double> v;
  std::stringstream cells(last);
  for (std::string cell; std::getline(cells, cell, ',');) v.push_back(std::stod(cell));
  ASSERT_EQ(v.size(), 6u);
  EXPECT_NEAR(v[4], s.val->flicker, 1e-5);  // the CSV has 6 significant digits
  EXPECT_NEAR(v[5], s.val->token_change_rate, 1e-5);
  // The moving shapes change some tokens; flicker is a share of them.
  EXPECT_GT(s.val->token_change_rate, 0.0);
  EXPECT_LE(s.val->token_change_rate, 1.0);
  EXPECT_GE(s.val->flicker, 0.0);
  EXPECT_LE(s.val->flicker, 1.0);
}

}  // namespace
}  // namespace wm::tokenize

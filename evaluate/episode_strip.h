#pragma once
// One PNG per scored episode (wm-eval --strips): the real frames on top, every imagined and
// baseline clip below them, and the first model rollout's error as a heat map, so a rollout can
// be judged by eye in one picture (docs/reports.md, "Strips").
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "evaluate/frame_scores.h"

namespace wm::evaluate {

// Geometry of a strip of frames `size` px a side, so readers can find every cell: cell (row r,
// column c) starts at x = kStripLabelWidth + c * (cell + kStripGap),
// y = kStripHeaderHeight + r * (cell + kStripGap), with cell = size * StripScale(size).
inline constexpr int kStripLabelWidth = 144;   // row labels at the left
inline constexpr int kStripHeaderHeight = 24;  // column labels (steps) on top
inline constexpr int kStripGap = 2;            // background between cells
// Nearest-neighbour upscale: ceil(192 / size), so 64 px frames become 192 px cells and frames of
// 192 px or more stay as they are.
int StripScale(int size);

// Row names top to bottom: "real", the model rollouts ("plain", "retrace"), the baselines
// ("copy_last", "tokenizer_recon", then any other kind in name order), and "error <rollout>" for
// the first model rollout present ("plain", else "retrace"; no error row without one).
std::vector<std::string> StripRows(const std::map<std::string, Clip>& clips);

// Writes DIR/episode_K.png atomically. `real`: the real frames 0..H; `clips`: kind -> frames
// 1..H (every scored clip; a "real" entry is ignored). Column 0 is frame 0, the real frame every
// rollout is given, in every row (the error row: its error, 0); columns 1..H are the steps.
void WriteEpisodeStrip(const std::string& dir, int64_t episode, const Clip& real,
                       const std::map<std::string, Clip>& clips);

// Writes DIR/overview.png atomically: the real, first model rollout and error rows of the strips
// DIR/episode_K.png of the first `count` of `episodes` (frames `size` px a side), stacked under
// one header, each row's label marked with its episode; strips of episodes shorter than the
// horizon are padded on the right to the widest. Reads the strips back, so a sharded
// run's completing job can draw strips that other jobs wrote. Does nothing without strips.
void WriteStripOverview(const std::string& dir, const std::vector<int64_t>& episodes, int count,
                        int size);

}  // namespace wm::evaluate

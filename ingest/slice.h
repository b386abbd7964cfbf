#pragma once
// `wm-shard slice`: a dataset of the same episodes from step `from_step` on (at most
// `max_steps` steps each), so that every tool that starts at an episode's first frame (wm-eval's
// rollouts, wm-tokenize encode, training) can start mid-episode instead: rollouts from where the
// arm is already near the block, or only the part of each episode where something is carried.
// Episodes with no step left after `from_step`, or with fewer than `min_steps`, are recorded in
// the index's `skipped` list. The first kept step is marked is_first; the per-step fields and
// every image stream are cut alike; action statistics are recomputed. It writes through
// wm-ingest's DatasetWriter: a killed run leaves no index.json, a rerun continues after the last
// finished shard, and the same input and options give the same bytes.
#include <cstdint>
#include <string>

#include "core/episode.h"
#include "core/shard/dataset_index.h"

namespace wm::ingest {

struct SliceOptions {
  std::string input, output;
  int64_t from_step = 0;
  int64_t max_steps = 0;  // 0: to the episode's end
  int64_t min_steps = 1;  // shorter slices are skipped (e.g. horizon + 1 for wm-eval)
};

// Episode `e` from step `from` on, `count` steps (count >= 1, from + count <= T); cut in place,
// so a moved-in episode's frames are not copied.
Episode SliceEpisode(Episode e, int64_t from, int64_t count);

// Throws wm::Error naming the input or output directory on bad options or input.
shard::DatasetIndex SliceDataset(const SliceOptions& options);

}  // namespace wm::ingest

#pragma once
// wm-gen-tabletop's library entry: writes a synthetic tabletop dataset in exactly the on-disk
// form TFDS gives an Open X-Embodiment RLDS dataset:
//   <out_dir>/<name>/<version>/dataset_info.json, features.json,
//   <name>-train.tfrecord-0000K-of-0000N, <name>-val.tfrecord-0000K-of-0000M
// one tf.train.Example per episode (keys in episode.h). Same options -> identical bytes.
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "ingest/tabletop/policies.h"
#include "ingest/tabletop/scene.h"

namespace wm::tabletop {

struct TabletopOptions {
  std::string out_dir;               // required; the dataset goes under <out_dir>/<name>/
  std::string name = "wm_tabletop";  // TFDS dataset name: [a-z][a-z0-9_]*
  std::string version = "1.0.0";     // TFDS version: MAJOR.MINOR.PATCH
  int train_episodes = 48;           // episodes in the "train" split (0 omits the split)
  int val_episodes = 16;             // episodes in the "val" split (0 omits the split)
  int files = 2;                     // TFRecord files per split (fewer if fewer episodes)
  int size = 128;                    // image side in pixels, 64..256
  int max_steps = 40;                // step limit per episode, 1..1000
  uint64_t seed = 0;                 // dataset seed; every episode derives its own from it
  // Policies assigned round-robin by episode index within each split.
  std::vector<std::string> policies = {"expert", "noisy", "random", "wrong_goal"};
  LookVariation look = LookVariation::kVaried;  // per-episode table texture and light, or plain
  GoalRegion goal_region;  // where goal centres are drawn from; default: the whole table

  // Throws wm::Error naming the offending option (as its command-line flag).
  void Check() const;
  // The policy for episode `index` of a split.
  PolicyKind PolicyForEpisode(int64_t index) const;
};

struct TabletopSummary {
  std::string dataset_dir;  // <out_dir>/<name>/<version>
  int episodes = 0;
  int64_t steps = 0;
  uint64_t bytes = 0;  // TFRecord bytes over all splits
  // policy name -> {episodes, successes}, over all splits.
  std::map<std::string, std::pair<int, int>> by_policy;
};

// Generates and writes the dataset (Check()s the options first). Each file is written
// atomically; stale shard files of an earlier run with another file count are removed, and
// dataset_info.json is written last.
TabletopSummary WriteTabletopDataset(const TabletopOptions& options);

// Parses wm-gen-tabletop's --goal-region "XMIN,XMAX,YMIN,YMAX" (metres); throws wm::Error (key
// "--goal-region") saying what was expected. TabletopOptions::Check checks the bounds.
GoalRegion ParseGoalRegion(const std::string& text);

// Removes TFRecord shard files of dataset `name` in `dir` that are not in `written` (left by an
// earlier run with other files or splits).
void RemoveStaleShards(const std::string& dir, const std::string& name,
                       const std::set<std::string>& written);

}  // namespace wm::tabletop

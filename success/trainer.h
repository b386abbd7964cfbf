#pragma once
// Training loop of the success classifier (torch-free interface; the work is in trainer.cc).
// RUN_DIR layout (docs/success.md):
//   checkpoint.wmt   model + AdamW moments; meta: model_kind "success", step, config, data
//   checkpoint.json  manifest: config, config hash, data hashes, provenance, step
//   metrics.csv      one row every train.log_every steps (has a throughput column)
//   val.csv          every frame of --val-data: loss, AUROC, accuracy vs the majority rule, and
//                    per-episode success accuracy
#include <cstdint>
#include <optional>
#include <string>

#include "success/config.h"

namespace wm::success {

struct TrainOptions {
  SuccessConfig config;
  std::string data_dir;  // shard dataset directory (index.json): frames and rewards
  std::string val_dir;   // held-out shard dataset for val.csv (optional)
  std::string out_dir;   // RUN_DIR, created if missing
  std::string device = "cpu";
  bool resume = false;  // continue from RUN_DIR/checkpoint.wmt
  // Stop (with a checkpoint) after this many steps of this invocation, 0 = run to train.steps.
  int64_t max_steps_this_run = 0;
  bool show_progress = true;
};

// One validation over every frame of the val data, P(success) > 0.5 deciding.
struct ValidationScore {
  double loss = 0;               // mean binary cross-entropy
  double auroc = 0;              // NaN when the val data has one class only
  double accuracy = 0;           // per frame
  double majority_accuracy = 0;  // per frame, always answering the commoner class
  double episode_accuracy = 0;   // an episode is a success when some frame is (vs its rewards)
  int64_t frames = 0, positives = 0;
};

struct TrainSummary {
  int64_t start_step = 0, end_step = 0;
  double first_loss = 0, last_loss = 0;
  std::optional<ValidationScore> val;
  std::string checkpoint_path;
};

// Throws wm::Error on bad data (no success frames), a config that differs from the checkpoint's
// on --resume, or a RUN_DIR that already holds a checkpoint without --resume.
TrainSummary TrainSuccess(const TrainOptions& options);

}  // namespace wm::success

#pragma once
// Training loop of the motion model (torch-free interface; the work is in trainer.cc).
// RUN_DIR layout (docs/motion.md):
//   checkpoint.wmt   model + AdamW moments; meta: step, config, action width and statistics
//   checkpoint.json  manifest: config, config hash, data hashes, provenance, step
//   metrics.csv      one row every train.log_every steps (has a throughput column)
//   val.csv          validation rollouts against copy_last and reversed actions (with --val-data)
#include <cstdint>
#include <optional>
#include <string>

#include "motion/config.h"

namespace wm::motion {

struct TrainOptions {
  MotionConfig config;
  std::string data_dir;  // shard dataset directory (index.json): frames and actions
  std::string val_dir;   // held-out shard dataset for val.csv (optional)
  std::string out_dir;   // RUN_DIR, created if missing
  std::string device = "cpu";
  bool resume = false;  // continue from RUN_DIR/checkpoint.wmt
  // Stop (with a checkpoint) after this many steps of this invocation, 0 = run to train.steps.
  int64_t max_steps_this_run = 0;
  bool show_progress = true;
};

// One validation: means over the val episodes of the per-frame PSNR (dB, on [0, 255] values)
// of `horizon` imagined frames from each episode's first frame.
struct RolloutScore {
  double psnr = 0;            // the logged actions
  double copy_last_psnr = 0;  // the first frame repeated
  double reversed_psnr = 0;   // the logged actions in reverse order (controllability)
  double delta_tpsnr() const { return psnr - reversed_psnr; }
};

struct TrainSummary {
  int64_t start_step = 0, end_step = 0;
  double first_loss = 0, last_loss = 0;
  std::optional<RolloutScore> val;
  std::string checkpoint_path;
};

// Throws wm::Error on bad data, a config that differs from the checkpoint's on --resume, or a
// RUN_DIR that already holds a checkpoint without --resume.
TrainSummary TrainMotion(const TrainOptions& options);

}  // namespace wm::motion

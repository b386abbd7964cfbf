#pragma once
// Training loop of the dynamics model (torch-free interface; the work is in trainer.cc).
// RUN_DIR layout (docs/dynamics.md):
//   checkpoint.wmt   model + AdamW moments; meta: step, config, action statistics, RNG scheme
//   checkpoint.json  manifest: config, config hash, token dataset hashes, tokenizer checkpoint
//                    sha256, provenance (git commit, LibTorch version), step, RNG scheme
//   metrics.csv      one row every train.log_every steps (has a wall-clock column)
#include <cstdint>
#include <string>
#include <vector>

#include "train/config.h"

namespace wm::train {

struct TrainOptions {
  DynamicsConfig config;
  std::vector<std::string> token_dirs;  // token datasets (each with index.json)
  std::string val_dir;                  // optional validation token dataset
  std::string out_dir;                  // RUN_DIR, created if missing
  std::string device = "cpu";           // "cpu", "cuda" or "cuda:N"
  bool resume = false;                  // continue from RUN_DIR/checkpoint.wmt
  // --init-from: a finished run (its directory or checkpoint.wmt) whose weights this run starts
  // from, with a fresh optimizer and schedule; empty = a random init. Once RUN_DIR has a
  // checkpoint, --resume continues it instead (the parent must be the one it recorded).
  std::string init_from;
  // --freeze: parameter groups kept fixed (no gradient, no AdamW update); needs init_from.
  // "policy" = the policy embedding (parameters under "policy.").
  std::vector<std::string> freeze;
  // Stop (with a checkpoint) after this many steps of this invocation, 0 = run to
  // train.steps; for time-sliced jobs. Does not change the schedule.
  int64_t max_steps_this_run = 0;
  bool show_progress = true;
  // Data parallelism (train/distributed.h): rank 0 of world_size writes the run directory.
  int rank = 0, world_size = 1;
  bool launched = false;  // WORLD_SIZE was in the environment (train/distributed.h)
  std::string master_addr = "127.0.0.1";
  int master_port = 0;
};

struct TrainSummary {
  int64_t start_step = 0, end_step = 0;
  double first_loss = 0, last_loss = 0;  // total loss of the first / last step of this run
  double last_token_ce = 0, last_token_accuracy = 0;
  double last_val_token_ce = -1, last_val_token_accuracy = -1;  // -1 = not evaluated
  double tokens_per_second = 0;  // training tokens (B * T * N) per second over this run
  double steps_per_second = 0;
  int64_t num_parameters = 0;
  std::string checkpoint_path;
};

// Throws wm::Error on bad data, a config that does not fit the data (grid, codes), a config
// (or --init-from parent) that differs from the checkpoint's on --resume, a parent whose shapes
// differ from the config's, or a RUN_DIR that already holds a checkpoint without --resume.
TrainSummary TrainDynamics(const TrainOptions& options);

// lr at `step` (trainkit::LearningRateAt on this config's schedule fields).
double LearningRateAt(const TrainConfig& train, int64_t step);

}  // namespace wm::train

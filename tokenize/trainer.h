#pragma once
// Training loop of the VQ-VAE tokenizer (torch-free interface; the work is in trainer.cc).
// RUN_DIR layout (docs/tokenizer.md):
//   checkpoint.wmt   model + AdamW moments, meta: step, RNG states (wmkit tensor archive)
//   checkpoint.json  manifest: config, config hash, data hashes, provenance, step, RNG states
//   metrics.csv      one row every train.log_every steps (has a wall-clock column)
//   val.csv          validation reconstruction PSNR/SSIM/L1 and token flicker (with --val-data)
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "tokenize/config.h"
#include "tokenize/validation.h"

namespace wm::tokenize {

struct TrainOptions {
  TokenizerConfig config;
  std::vector<std::string> data_dirs;  // shard dataset directories (each with index.json)
  std::string mixture_file;            // configs/mixtures/*.yaml; empty = weight by step count
  std::vector<std::string> val_dirs;   // validation datasets for val.csv (optional)
  std::string out_dir;                 // RUN_DIR, created if missing
  std::string device = "cpu";          // "cpu", "cuda" or "cuda:N"
  bool resume = false;                 // continue from RUN_DIR/checkpoint.wmt
  // --init-from: a finished run (its directory or checkpoint.wmt) whose weights, codebook and
  // dead-code counters this run starts from, with a fresh optimizer, schedule and dead-code RNG;
  // empty = a random init. Once RUN_DIR has a checkpoint, --resume continues it instead (the
  // parent must be the one it recorded).
  std::string init_from;
  // --freeze: parameter groups kept fixed (no gradient, no AdamW update); needs init_from.
  // "encoder" = the encoder and the codebook (no dead-code re-seeding): tokens stay identical.
  std::vector<std::string> freeze;
  // Stop (with a checkpoint) after this many steps of this invocation, 0 = run to
  // train.steps; for time-sliced jobs. Does not change the schedule.
  int64_t max_steps_this_run = 0;
  bool show_progress = true;
};

struct TrainSummary {
  int64_t start_step = 0, end_step = 0;
  double last_loss = 0, first_loss = 0;  // of the first / last step of this invocation
  double last_recon_l1 = 0, last_perplexity = 0;
  std::optional<ReconstructionScore> val;  // the last validation, when --val-data was given
  std::string checkpoint_path;
};

// Throws wm::Error on bad data, a config (or --init-from parent) that differs from the
// checkpoint's on --resume, a parent whose shapes differ from the config's, or a RUN_DIR that
// already holds a checkpoint without --resume.
TrainSummary TrainTokenizer(const TrainOptions& options);

// lr at `step` (0-based): trainkit::LearningRateAt (linear warmup to max_lr over warmup_steps,
// then cosine to min_lr at train.steps) on this config's schedule fields.
double LearningRateAt(const TrainConfig& train, int64_t step);

}  // namespace wm::tokenize

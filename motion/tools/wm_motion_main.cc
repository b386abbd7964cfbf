// wm-motion: train the action-conditioned warp predictor on a shard dataset (docs/motion.md).
// Exit codes: 0 success, 1 a wmkit error (bad config, data, checkpoint), 2 a bad command line.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>
#include <optional>

#include "core/cli_parse.h"
#include "core/log.h"
#include "core/malloc_tuning.h"
#include "core/provenance.h"
#include "motion/trainer.h"

namespace {

struct TrainArgs {
  std::string config;
  wm::motion::TrainOptions options;
  int64_t steps = 0, stop_after = 0;
  int threads = 0;
  std::optional<uint64_t> seed;
};

void AddTrain(CLI::App& app, TrainArgs& a) {
  CLI::App* train = app.add_subcommand("train", "Train a motion model from a shard dataset");
  train->footer(
      "Example:\n  wm-motion train --config configs/motion/tiny.yaml \\\n"
      "    --data data/demo/shards/train --val-data data/demo/shards/val --out runs/motion\n"
      "Re-running with --resume continues from RUN_DIR/checkpoint.wmt; the final checkpoint is\n"
      "byte-identical to an uninterrupted CPU run.");
  train->add_option("--config", a.config, "Motion model YAML (configs/motion/*.yaml)")
      ->required()
      ->check(CLI::ExistingFile);
  train->add_option("--data", a.options.data_dir, "Shard dataset directory (frames + actions)")
      ->required()
      ->check(CLI::ExistingDirectory);
  train->add_option("--out", a.options.out_dir, "Run directory (RUN_DIR)")->required();
  train
      ->add_option("--val-data", a.options.val_dir,
                   "Held-out shard dataset: rollout PSNR vs copy_last and reversed actions to "
                   "RUN_DIR/val.csv")
      ->check(CLI::ExistingDirectory);
  train->add_option("--steps", a.steps, "Override train.steps");
  train->add_option("--device", a.options.device, "cpu, cuda or cuda:N")->capture_default_str();
  train->add_option("--seed", a.seed, "Override train.seed");
  train->add_option("--threads", a.threads, "Override train.threads (LibTorch intra-op)");
  train->add_flag("--resume", a.options.resume, "Continue from RUN_DIR/checkpoint.wmt");
  train->add_option("--stop-after", a.stop_after,
                    "Stop after N steps of this invocation (time-sliced jobs)");
}

int RunTrain(TrainArgs& a) {
  auto& o = a.options;
  o.config = wm::motion::LoadMotionConfig(a.config);
  if (a.steps > 0) o.config.train.steps = a.steps;
  if (a.seed) o.config.train.seed = *a.seed;
  if (a.threads > 0) o.config.train.threads = a.threads;
  o.max_steps_this_run = a.stop_after;
  const auto summary = wm::motion::TrainMotion(o);
  if (summary.start_step == summary.end_step) {  // a resumed run that had already finished
    spdlog::info("already at step {}: nothing to train; {} kept", summary.end_step,
                 summary.checkpoint_path);
    return 0;
  }
  spdlog::info("steps {}..{}: L1 loss {:.4f} (first {:.4f}); wrote {}", summary.start_step,
               summary.end_step, summary.last_loss, summary.first_loss, summary.checkpoint_path);
  if (summary.val) {
    spdlog::info(
        "validation rollouts: PSNR {:.2f} dB (copy_last {:.2f}); with the actions reversed "
        "{:.2f} (delta_tpsnr {:+.2f} dB)",
        summary.val->psnr, summary.val->copy_last_psnr, summary.val->reversed_psnr,
        summary.val->delta_tpsnr());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  wm::KeepLargeAllocationsInHeap();
  CLI::App app{"wm-motion: action-conditioned warp predictor (pixel-space world model)"};
  app.footer(
      "Example:\n  wm-motion train --config configs/motion/tiny.yaml --data "
      "data/demo/shards/train \\\n"
      "    --val-data data/demo/shards/val --out runs/motion\n"
      "Exit codes: 0 success, 1 error (one line naming the file), 2 bad command line.");
  app.set_version_flag("--version", wm::VersionString("wm-motion"));
  app.require_subcommand(1);
  TrainArgs train;
  AddTrain(app, train);
  if (const int rc = wm::ParseCommandLine(app, argc, argv); rc >= 0) return rc;
  wm::InitLogging();
  try {
    if (app.got_subcommand("train")) return RunTrain(train);
  } catch (const std::exception& e) {
    std::cerr << "wm-motion: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

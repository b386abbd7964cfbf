// wm-motion: train the action-conditioned warp predictor on a shard dataset (docs/motion.md).
// Exit codes: 0 success, 1 a wmkit error (bad config, data, checkpoint), 2 a bad command line.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>

#include "core/cli_parse.h"
#include "core/log.h"
#include "core/malloc_tuning.h"
#include "core/provenance.h"
#include "motion/trainer.h"
#include "trainkit/tools/train_command.h"

namespace {

struct TrainArgs {
  wm::trainkit::TrainOverrides overrides;
  wm::motion::TrainOptions options;
};

void AddTrain(CLI::App& app, TrainArgs& a) {
  wm::trainkit::AddTrainCommand(
      app,
      {.description = "Train a motion model from a shard dataset",
       .footer = "Example:\n  wm-motion train --config configs/motion/tiny.yaml \\\n"
                 "    --data data/demo/shards/train --val-data data/demo/shards/val --out "
                 "runs/motion\n"
                 "Re-running with --resume continues from RUN_DIR/checkpoint.wmt; the final "
                 "checkpoint is\nbyte-identical to an uninterrupted CPU run.",
       .config_help = "Motion model YAML (configs/motion/*.yaml)",
       .data_help = "Shard dataset directory (frames + actions)",
       .val_help = "Held-out shard dataset: rollout PSNR vs copy_last and reversed actions to "
                   "RUN_DIR/val.csv"},
      a.options, a.overrides);
}

int RunTrain(TrainArgs& a) {
  a.options.config = wm::motion::LoadMotionConfig(a.overrides.config);
  wm::trainkit::ApplyTrainOverrides(a.overrides, a.options);
  const auto summary = wm::motion::TrainMotion(a.options);
  // The pose kind's last steps are its dynamics': their loss is a scaled pose error.
  const bool posed = a.options.config.model.kind == "pose";
  if (!wm::trainkit::LogTrainSummary(summary, posed ? "loss" : "L1 loss")) return 0;
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

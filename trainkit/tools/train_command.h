#pragma once
// The `train` subcommand that wm-motion and wm-success share: the same options (config, data,
// run directory, validation data, step/seed/thread overrides, device, --resume, --stop-after)
// on each stage's TrainOptions, the overrides applied to the loaded config, and the closing log
// line. Header-only: a template over the stage's TrainOptions and TrainSummary, which name their
// fields alike (data_dir, val_dir, out_dir, device, resume, max_steps_this_run; start_step,
// end_step, first_loss, last_loss, checkpoint_path).
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cstdint>
#include <optional>
#include <string>

namespace wm::trainkit {

// What the command line says beyond the stage's TrainOptions.
struct TrainOverrides {
  std::string config;  // the YAML file
  int64_t steps = 0, stop_after = 0;
  int threads = 0;
  std::optional<uint64_t> seed;
};

// What differs between the stages' `train` subcommands: their words.
struct TrainCommandText {
  std::string description;  // the subcommand's one line
  std::string footer;       // its example and notes
  std::string config_help;  // "... YAML (configs/<stage>/*.yaml)"
  std::string data_help;    // what --data must hold
  std::string val_help;     // what --val-data is scored on, and where it goes
};

template <class Options>
CLI::App* AddTrainCommand(CLI::App& app, const TrainCommandText& text, Options& o,
                          TrainOverrides& a) {
  CLI::App* train = app.add_subcommand("train", text.description);
  train->footer(text.footer);
  train->add_option("--config", a.config, text.config_help)->required()->check(CLI::ExistingFile);
  train->add_option("--data", o.data_dir, text.data_help)
      ->required()
      ->check(CLI::ExistingDirectory);
  train->add_option("--out", o.out_dir, "Run directory (RUN_DIR)")->required();
  train->add_option("--val-data", o.val_dir, text.val_help)->check(CLI::ExistingDirectory);
  train->add_option("--steps", a.steps, "Override train.steps")->check(CLI::Range(1, 1 << 30));
  train->add_option("--device", o.device, "cpu, cuda or cuda:N")->capture_default_str();
  train->add_option("--seed", a.seed, "Override train.seed");
  train->add_option("--threads", a.threads, "Override train.threads (LibTorch intra-op)");
  train->add_flag("--resume", o.resume, "Continue from RUN_DIR/checkpoint.wmt");
  train->add_option("--stop-after", a.stop_after,
                    "Stop after N steps of this invocation (time-sliced jobs)");
  return train;
}

// The overrides on `o.config.train` (steps, seed, threads) and on the invocation's step budget.
template <class Options>
void ApplyTrainOverrides(const TrainOverrides& a, Options& o) {
  if (a.steps > 0) o.config.train.steps = a.steps;
  if (a.seed) o.config.train.seed = *a.seed;
  if (a.threads > 0) o.config.train.threads = a.threads;
  o.max_steps_this_run = a.stop_after;
}

// Logs what the invocation did, the loss under `loss_name`; false when a resumed run had already
// finished (nothing trained, so there is no validation to report either).
template <class Summary>
bool LogTrainSummary(const Summary& summary, const char* loss_name) {
  if (summary.start_step == summary.end_step) {
    spdlog::info("already at step {}: nothing to train; {} kept", summary.end_step,
                 summary.checkpoint_path);
    return false;
  }
  spdlog::info("steps {}..{}: {} {:.4f} (first {:.4f}); wrote {}", summary.start_step,
               summary.end_step, loss_name, summary.last_loss, summary.first_loss,
               summary.checkpoint_path);
  return true;
}

}  // namespace wm::trainkit

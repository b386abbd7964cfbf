// wm-tokenize: train the VQ-VAE video tokenizer on shard datasets (docs/tokenizer.md).
// Exit codes: 0 success, 1 a wmkit error (bad config, data, checkpoint), CLI11 codes (>= 100)
// for a bad command line.
#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>
#include <optional>

#include "core/error.h"
#include "core/log.h"
#include "core/provenance.h"
#include "tokenize/trainer.h"

namespace {

struct TrainArgs {
  std::string config;
  wm::tokenize::TrainOptions options;
  int64_t steps = 0, stop_after = 0;
  int threads = 0;
  std::optional<uint64_t> seed;
};

void AddTrain(CLI::App& app, TrainArgs& a) {
  CLI::App* train = app.add_subcommand("train", "Train a tokenizer from shard datasets");
  train->footer(
      "Example:\n  wm-tokenize train --config configs/tokenizer/tiny.yaml \\\n"
      "    --data data/tabletop/train --out runs/tok-tiny\n"
      "Re-running with --resume continues from RUN_DIR/checkpoint.wmt; the final checkpoint is\n"
      "byte-identical to an uninterrupted CPU run.");
  train->add_option("--config", a.config, "Tokenizer YAML (configs/tokenizer/*.yaml)")
      ->required()
      ->check(CLI::ExistingFile);
  train->add_option("--data", a.options.data_dirs, "Shard dataset directories")
      ->required()
      ->check(CLI::ExistingDirectory);
  train->add_option("--out", a.options.out_dir, "Run directory (RUN_DIR)")->required();
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
  o.config = wm::tokenize::LoadTokenizerConfig(a.config);
  if (a.steps > 0) o.config.train.steps = a.steps;
  if (a.seed) o.config.train.seed = *a.seed;
  if (a.threads > 0) o.config.train.threads = a.threads;
  o.max_steps_this_run = a.stop_after;
  const auto summary = wm::tokenize::TrainTokenizer(o);
  spdlog::info("steps {}..{}: loss {:.4f}, recon L1 {:.4f}, perplexity {:.1f}; wrote {}",
               summary.start_step, summary.end_step, summary.last_loss, summary.last_recon_l1,
               summary.last_perplexity, summary.checkpoint_path);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"wm-tokenize: VQ-VAE video tokenizer for wmkit world models"};
  app.set_version_flag("--version", wm::VersionString("wm-tokenize"));
  app.require_subcommand(1);
  TrainArgs train;
  AddTrain(app, train);
  CLI11_PARSE(app, argc, argv);
  wm::InitLogging();
  try {
    if (app.got_subcommand("train")) return RunTrain(train);
  } catch (const std::exception& e) {
    std::cerr << "wm-tokenize: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

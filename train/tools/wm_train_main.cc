// wm-train: train the action- and policy-conditioned dynamics model on token datasets
// (docs/dynamics.md). Exit codes: 0 success, 1 a wmkit error (bad config, data, checkpoint) or a
// failed rank, 2 for a bad command line.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <optional>

#include "core/cli_parse.h"
#include "core/error.h"
#include "core/log.h"
#include "core/malloc_tuning.h"
#include "core/provenance.h"
#include "train/launch.h"
#include "train/trainer.h"

namespace {

struct Args {
  std::string config;
  wm::train::TrainOptions options;
  int64_t steps = 0, stop_after = 0;
  int threads = 0, nproc = 0;
  std::optional<uint64_t> seed;
};

void AddOptions(CLI::App& app, Args& a) {
  app.footer(
      "Example:\n  wm-train --config configs/dynamics/tiny.yaml --tokens data/tokens/train \\\n"
      "    --val-tokens data/tokens/val --out runs/dyn-tiny\n"
      "Data parallel: --nproc 2 (local processes), or torchrun-style RANK, WORLD_SIZE,\n"
      "MASTER_ADDR, MASTER_PORT in the environment of every process.\n"
      "Re-running with --resume continues from RUN_DIR/checkpoint.wmt; the final checkpoint is\n"
      "byte-identical to an uninterrupted CPU run.\n"
      "Fine-tuning: --init-from runs/dyn-tiny [--freeze policy] starts from that run's weights\n"
      "(fresh optimizer and schedule); the parent's checkpoint sha256 is recorded, not its path.\n"
      "Exit codes: 0 success, 1 error (one line naming file and key), 2 bad command line.");
  app.add_option("--config", a.config, "Dynamics YAML (configs/dynamics/*.yaml)")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--tokens", a.options.token_dirs, "Token dataset directories (wm-tokenize encode)")
      ->required()
      ->check(CLI::ExistingDirectory);
  app.add_option("--val-tokens", a.options.val_dir, "Validation token dataset")
      ->check(CLI::ExistingDirectory);
  app.add_option("--out", a.options.out_dir, "Run directory (RUN_DIR)")->required();
  app.add_option("--steps", a.steps, "Override train.steps")->check(CLI::Range(1, 1 << 30));
  app.add_option("--device", a.options.device, "cpu, cuda or cuda:N")->capture_default_str();
  app.add_option("--seed", a.seed, "Override train.seed");
  app.add_option("--threads", a.threads, "Override train.threads (LibTorch intra-op, per rank)");
  app.add_flag("--resume", a.options.resume, "Continue from RUN_DIR/checkpoint.wmt");
  app.add_option("--init-from", a.options.init_from,
                 "Start from the weights of this finished run (RUN_DIR or checkpoint.wmt)")
      ->check(CLI::ExistingPath);
  app.add_option("--freeze", a.options.freeze,
                 "With --init-from: keep these parameters fixed (policy = the policy embedding)")
      ->check(CLI::IsMember({"policy"}))
      ->needs("--init-from");
  app.add_option("--stop-after", a.stop_after,
                 "Stop after N steps of this invocation (time-sliced jobs)");
  app.add_option("--nproc", a.nproc, "Spawn N local data-parallel processes (Gloo/store on CPU)");
}

int Run(Args& a, int argc, char** argv) {
  auto& o = a.options;
  o.config = wm::train::LoadDynamicsConfig(a.config);
  if (a.steps > 0) o.config.train.steps = a.steps;
  if (a.seed) o.config.train.seed = *a.seed;
  if (a.threads > 0) o.config.train.threads = a.threads;
  o.max_steps_this_run = a.stop_after;
  if (a.nproc > 1) return wm::train::SpawnLocalRanks(a.nproc, argc, argv);
  wm::train::ReadDistributedEnvironment(o);
  const auto s = wm::train::TrainDynamics(o);
  if (o.rank == 0 && s.start_step == s.end_step) {  // a resumed run that had already finished
    spdlog::info("already at step {}: nothing to train; {} kept", s.end_step, s.checkpoint_path);
  } else if (o.rank == 0) {
    spdlog::info(
        "steps {}..{}: loss {:.4f}, token CE {:.4f}, token acc {:.3f}{}; {:.2f} steps/s, "
        "{:.0f} tokens/s, {} parameters; wrote {}",
        s.start_step, s.end_step, s.last_loss, s.last_token_ce, s.last_token_accuracy,
        s.last_val_token_accuracy >= 0
            ? fmt::format(", val next-frame acc {:.3f}", s.last_val_token_accuracy)
            : std::string(),
        s.steps_per_second, s.tokens_per_second, s.num_parameters, s.checkpoint_path);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  wm::KeepLargeAllocationsInHeap();
  CLI::App app{"wm-train: action- and policy-conditioned ST-transformer dynamics model"};
  app.set_version_flag("--version", wm::VersionString("wm-train"));
  Args args;
  AddOptions(app, args);
  if (const int rc = wm::ParseCommandLine(app, argc, argv); rc >= 0) return rc;
  wm::InitLogging();
  try {
    return Run(args, argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "wm-train: error: " << e.what() << "\n";
    return 1;
  }
}

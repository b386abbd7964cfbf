// wm-tokenize: train the VQ-VAE video tokenizer on shard datasets, pre-tokenize datasets into
// token datasets and decode them for inspection (docs/tokenizer.md, docs/token-format.md).
// Exit codes: 0 success, 1 a wmkit error (bad config, data, checkpoint), 2 a bad command line.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>
#include <optional>

#include "core/cli_parse.h"
#include "core/error.h"
#include "core/log.h"
#include "core/malloc_tuning.h"
#include "core/provenance.h"
#include "tokenize/decode.h"
#include "tokenize/encode.h"
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
      "byte-identical to an uninterrupted CPU run.\n"
      "Fine-tuning: --init-from runs/tok-tiny [--freeze encoder] starts from that run's weights\n"
      "(fresh optimizer and schedule); the parent's checkpoint sha256 is recorded, not its path.");
  train->add_option("--config", a.config, "Tokenizer YAML (configs/tokenizer/*.yaml)")
      ->required()
      ->check(CLI::ExistingFile);
  train->add_option("--data", a.options.data_dirs, "Shard dataset directories")
      ->required()
      ->check(CLI::ExistingDirectory);
  train->add_option("--out", a.options.out_dir, "Run directory (RUN_DIR)")->required();
  train
      ->add_option("--val-data", a.options.val_dirs,
                   "Validation shard datasets: reconstruction PSNR/SSIM and token flicker to "
                   "RUN_DIR/val.csv")
      ->check(CLI::ExistingDirectory);
  train
      ->add_option("--mixture", a.options.mixture_file,
                   "Dataset weights (configs/mixtures/*.yaml); default: by step count")
      ->check(CLI::ExistingFile);
  train->add_option("--steps", a.steps, "Override train.steps");
  train->add_option("--device", a.options.device, "cpu, cuda or cuda:N")->capture_default_str();
  train->add_option("--seed", a.seed, "Override train.seed");
  train->add_option("--threads", a.threads, "Override train.threads (LibTorch intra-op)");
  train->add_flag("--resume", a.options.resume, "Continue from RUN_DIR/checkpoint.wmt");
  train
      ->add_option("--init-from", a.options.init_from,
                   "Start from the weights of this finished run (RUN_DIR or checkpoint.wmt)")
      ->check(CLI::ExistingPath);
  train
      ->add_option("--freeze", a.options.freeze,
                   "With --init-from: keep these parameters fixed (encoder = encoder + codebook, "
                   "so tokens stay identical)")
      ->check(CLI::IsMember({"encoder"}))
      ->needs("--init-from");
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
  if (summary.start_step == summary.end_step) {  // a resumed run that had already finished
    spdlog::info("already at step {}: nothing to train; {} kept", summary.end_step,
                 summary.checkpoint_path);
    return 0;
  }
  spdlog::info("steps {}..{}: loss {:.4f}, recon L1 {:.4f}, perplexity {:.1f}; wrote {}",
               summary.start_step, summary.end_step, summary.last_loss, summary.last_recon_l1,
               summary.last_perplexity, summary.checkpoint_path);
  if (summary.val) {
    spdlog::info(
        "validation reconstruction: PSNR {:.2f} dB, SSIM {:.4f}; token flicker {:.3f} (share of "
        "token changes in cells whose pixels did not change), token change rate {:.3f}",
        summary.val->psnr, summary.val->ssim, summary.val->flicker, summary.val->token_change_rate);
  }
  return 0;
}

void AddEncode(CLI::App& app, wm::tokenize::EncodeOptions& o) {
  CLI::App* encode = app.add_subcommand("encode", "Pre-tokenize a shard dataset");
  encode->footer(
      "Example:\n  wm-tokenize encode --checkpoint runs/tok-tiny --data data/tabletop/train \\\n"
      "    --out data/tabletop-tokens/train\n"
      "As a Slurm array: add --shard-index $SLURM_ARRAY_TASK_ID --num-shards "
      "$SLURM_ARRAY_TASK_COUNT;\n"
      "index.json appears when the last part is written. A rerun skips finished parts.");
  encode->add_option("--checkpoint", o.checkpoint, "Tokenizer run directory or checkpoint.wmt")
      ->required()
      ->check(CLI::ExistingPath);
  encode->add_option("--data", o.data_dir, "Shard dataset directory")
      ->required()
      ->check(CLI::ExistingDirectory);
  encode->add_option("--out", o.out_dir, "Token dataset directory (TOKENS_DIR)")->required();
  encode->add_option("--shard-index", o.shard_index, "This job's part")->capture_default_str();
  encode->add_option("--num-shards", o.num_shards, "Number of parts")->capture_default_str();
  encode->add_option("--device", o.device, "cpu, cuda or cuda:N")->capture_default_str();
  encode->add_option("--threads", o.threads, "LibTorch intra-op threads")->capture_default_str();
  encode
      ->add_option("--hysteresis", o.hysteresis,
                   "Keep a cell's previous code while it is within this distance of the nearest "
                   "(cosine lookup: 2 - 2 cos); 0 = none")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
}

int RunEncode(const wm::tokenize::EncodeOptions& o) {
  const auto s = wm::tokenize::EncodeDataset(o);
  if (s.skipped) spdlog::info("part {} was already encoded; kept", o.shard_index);
  spdlog::info("encoded {} episodes, {} frames into {}{}", s.episodes, s.frames, o.out_dir,
               s.index_written ? " (index.json written)" : " (waiting for other parts)");
  return 0;
}

void AddDecode(CLI::App& app, wm::tokenize::DecodeOptions& o) {
  CLI::App* decode = app.add_subcommand("decode", "Decode an episode's tokens to PNG or MP4");
  decode->footer(
      "Example:\n  wm-tokenize decode --checkpoint runs/tok-tiny --tokens data/tabletop-tokens/val "
      "\\\n"
      "    --episode 0 --originals data/tabletop/val --out recon.png\n"
      "OUT ending in .png: contact sheet (originals above decoded frames with --originals);\n"
      ".mp4: video (side by side with --originals); anything else: a folder of PNG frames.");
  decode->add_option("--checkpoint", o.checkpoint, "The tokenizer that wrote the tokens")
      ->required()
      ->check(CLI::ExistingPath);
  decode->add_option("--tokens", o.tokens_dir, "Token dataset directory")
      ->required()
      ->check(CLI::ExistingDirectory);
  decode->add_option("--episode", o.episode, "Episode index")->capture_default_str();
  decode->add_option("--out", o.out, "Output .png, .mp4 or folder")->required();
  decode->add_option("--originals", o.originals_dir, "Source shard dataset, for comparison")
      ->check(CLI::ExistingDirectory);
  decode->add_option("--columns", o.columns, "Frames per row of the .png")->capture_default_str();
  decode->add_option("--device", o.device, "cpu, cuda or cuda:N")->capture_default_str();
}

}  // namespace

int main(int argc, char** argv) {
  wm::KeepLargeAllocationsInHeap();
  CLI::App app{"wm-tokenize: VQ-VAE video tokenizer for wmkit world models"};
  app.footer(
      "Example:\n  wm-tokenize train --config configs/tokenizer/tiny.yaml --data "
      "data/demo/shards/train \\\n"
      "    --out runs/tok\n  wm-tokenize encode --checkpoint runs/tok --data data/demo/shards/val "
      "\\\n"
      "    --out runs/tokens/val\n"
      "Exit codes: 0 success, 1 error (one line naming the file), 2 bad command line.");
  app.set_version_flag("--version", wm::VersionString("wm-tokenize"));
  app.require_subcommand(1);
  TrainArgs train;
  AddTrain(app, train);
  wm::tokenize::EncodeOptions encode;
  AddEncode(app, encode);
  wm::tokenize::DecodeOptions decode;
  AddDecode(app, decode);
  if (const int rc = wm::ParseCommandLine(app, argc, argv); rc >= 0) return rc;
  wm::InitLogging();
  try {
    if (app.got_subcommand("train")) return RunTrain(train);
    if (app.got_subcommand("encode")) return RunEncode(encode);
    if (app.got_subcommand("decode")) {
      const int64_t n = wm::tokenize::DecodeEpisode(decode);
      spdlog::info("decoded {} frames of episode {} to {}", n, decode.episode, decode.out);
    }
  } catch (const std::exception& e) {
    std::cerr << "wm-tokenize: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

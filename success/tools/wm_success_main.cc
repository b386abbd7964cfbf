// wm-success: train the success classifier that scores imagined frames in closed-loop policy
// evaluation, and score real episodes with it (docs/success.md). Exit codes: 0 success, 1 a wmkit
// error (bad config, data, checkpoint), 2 a bad command line.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <array>
#include <exception>
#include <iostream>
#include <map>

#include "core/atomic_file.h"
#include "core/cli_parse.h"
#include "core/log.h"
#include "core/malloc_tuning.h"
#include "core/provenance.h"
#include "success/score.h"
#include "success/success_model.h"
#include "success/trainer.h"
#include "trainkit/tools/train_command.h"

namespace {

struct TrainArgs {
  wm::trainkit::TrainOverrides overrides;
  wm::success::TrainOptions options;
};

void AddTrain(CLI::App& app, TrainArgs& a) {
  wm::trainkit::AddTrainCommand(
      app,
      {.description = "Train a success classifier on a shard dataset's frames",
       .footer =
           "Example:\n  wm-success train --config configs/success/tiny.yaml \\\n"
           "    --data data/demo/shards/train --val-data data/demo/shards/val --out runs/success\n"
           "Labels: a frame is a success frame when the reward logged with it exceeds\n"
           "data.reward_threshold (tabletop: the frame showing the block in the goal). Re-running\n"
           "with --resume continues from RUN_DIR/checkpoint.wmt; the final checkpoint is\n"
           "byte-identical to an uninterrupted CPU run. Use: wm-eval --policy ... --success-model "
           "RUN_DIR.",
       .config_help = "Success classifier YAML (configs/success/*.yaml)",
       .data_help = "Shard dataset directory (frames + rewards)",
       .val_help = "Held-out shard dataset: loss, AUROC and accuracies to RUN_DIR/val.csv"},
      a.options, a.overrides);
}

int RunTrain(TrainArgs& a) {
  a.options.config = wm::success::LoadSuccessConfig(a.overrides.config);
  wm::trainkit::ApplyTrainOverrides(a.overrides, a.options);
  const auto summary = wm::success::TrainSuccess(a.options);
  if (!wm::trainkit::LogTrainSummary(summary, "cross-entropy")) return 0;
  if (const auto& v = summary.val) {
    spdlog::info(
        "validation ({} frames, {} success): AUROC {:.3f}, accuracy {:.3f} (majority rule "
        "{:.3f}), episodes right {:.3f}",
        v->frames, v->positives, v->auroc, v->accuracy, v->majority_accuracy, v->episode_accuracy);
  }
  return 0;
}

struct ScoreArgs {
  std::string checkpoint, data, out, device = "cpu";
  int threads = 1;
};

void AddScore(CLI::App& app, ScoreArgs& a) {
  CLI::App* score = app.add_subcommand(
      "score", "Score every episode of a shard dataset with a trained success classifier");
  score->footer(
      "Example:\n  wm-success score --checkpoint runs/success --data data/sim/shards/colour \\\n"
      "    --out scores.csv\n"
      "An episode is predicted a success when some frame's P(success) > 0.5 (as wm-eval --policy\n"
      "decides in imagination); scores.csv has one row per episode beside the success its rewards\n"
      "log; the log gives per policy_id the predicted and the logged success rate.");
  score->add_option("--checkpoint", a.checkpoint, "wm-success train's RUN_DIR")
      ->required()
      ->check(CLI::ExistingPath);
  score->add_option("--data", a.data, "Shard dataset directory")
      ->required()
      ->check(CLI::ExistingDirectory);
  score->add_option("--out", a.out, "scores.csv to write")->required();
  score->add_option("--device", a.device, "cpu, cuda or cuda:N")->capture_default_str();
  score->add_option("--threads", a.threads, "LibTorch intra-op threads")->capture_default_str();
}

int RunScore(const ScoreArgs& a) {
  const auto model = wm::success::SuccessModel::Load(a.checkpoint, a.device, a.threads);
  const auto scores = wm::success::ScoreEpisodes(*model, a.data);
  wm::WriteFileAtomically(a.out, wm::success::ScoresCsv(scores));
  std::map<std::string, std::array<int64_t, 3>> by_policy;  // episodes, predicted, logged
  int64_t right = 0;
  for (const auto& s : scores) {
    auto& n = by_policy[s.policy_id.empty() ? "(unknown)" : s.policy_id];
    n[0] += 1, n[1] += s.predicted_success, n[2] += s.logged_success;
    right += s.predicted_success == s.logged_success;
  }
  for (const auto& [policy, n] : by_policy) {
    spdlog::info("{}: predicted success {} of {} episodes, logged {}", policy, n[1], n[0], n[2]);
  }
  spdlog::info("{} of {} episodes called right; wrote {}", right, scores.size(), a.out);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  wm::KeepLargeAllocationsInHeap();
  CLI::App app{"wm-success: success classifier on real frames (scores imagined episodes)"};
  app.footer(
      "Example:\n  wm-success train --config configs/success/tiny.yaml --data "
      "data/demo/shards/train \\\n"
      "    --val-data data/demo/shards/val --out runs/success\n"
      "Exit codes: 0 success, 1 error (one line naming the file), 2 bad command line.");
  app.set_version_flag("--version", wm::VersionString("wm-success"));
  app.require_subcommand(1);
  TrainArgs train;
  AddTrain(app, train);
  ScoreArgs score;
  AddScore(app, score);
  if (const int rc = wm::ParseCommandLine(app, argc, argv); rc >= 0) return rc;
  wm::InitLogging();
  try {
    if (app.got_subcommand("train")) return RunTrain(train);
    if (app.got_subcommand("score")) return RunScore(score);
  } catch (const std::exception& e) {
    std::cerr << "wm-success: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

// wm-gen-tabletop: writes a synthetic tabletop RLDS dataset in TFDS's on-disk form.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <iostream>

#include "core/error.h"
#include "core/log.h"
#include "core/provenance.h"
#include "ingest/tabletop/tabletop_writer.h"

namespace {

constexpr const char* kFooter = R"(
Writes <out>/<name>/<version>/{dataset_info.json, features.json,
<name>-{train,val}.tfrecord-0000K-of-0000N}: one tf.train.Example per episode, byte-compatible
with what TFDS writes for an Open X-Embodiment RLDS dataset. Per step: RGB JPEG, 16-bit depth
PNG (mm), segmentation PNG (0 table, 1 arm+gripper, 2 block, 3 goal), 7-dim action, reward 1 on
the terminal step (block in goal). Same arguments -> identical bytes.

Examples:
  wm-gen-tabletop --out data/rlds
  wm-gen-tabletop --out data/rlds --train-episodes 200 --size 64 --policies expert,random
  wm-gen-tabletop --out data/new_task --look plain --goal-region=0.05,0.2,-0.05,0.35

Exit codes: 0 success, 1 invalid option or write failure, 2 usage error.)";

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"wm-gen-tabletop: synthetic tabletop pick-and-place dataset (TFDS/RLDS layout)"};
  app.footer(kFooter);
  wm::tabletop::TabletopOptions opts;
  app.add_option("--out", opts.out_dir, "Output directory (the dataset goes to OUT/NAME/VERSION)");
  app.add_option("--name", opts.name, "TFDS dataset name")->capture_default_str();
  app.set_version_flag("--version", wm::VersionString("wm-gen-tabletop"));
  app.add_option("--dataset-version", opts.version, "TFDS dataset version")->capture_default_str();
  app.add_option("--train-episodes", opts.train_episodes, "Episodes in the train split")
      ->capture_default_str();
  app.add_option("--val-episodes", opts.val_episodes, "Episodes in the val split")
      ->capture_default_str();
  app.add_option("--files", opts.files, "TFRecord files per split")->capture_default_str();
  app.add_option("--size", opts.size, "Image side in pixels (64..256)")->capture_default_str();
  app.add_option("--max-steps", opts.max_steps, "Step limit per episode")->capture_default_str();
  app.add_option("--seed", opts.seed, "Dataset seed")->capture_default_str();
  app.add_option("--policies", opts.policies,
                 "Comma-separated mix, assigned round-robin: expert,noisy,random,wrong_goal")
      ->delimiter(',')
      ->capture_default_str();
  std::string look = "varied";
  app.add_option("--look", look,
                 "varied: per-episode table texture and light; plain: one untextured table and "
                 "light (same layouts and actions)")
      ->check(CLI::IsMember({"varied", "plain"}))
      ->capture_default_str();
  std::string goal_region;
  app.add_option("--goal-region", goal_region,
                 "XMIN,XMAX,YMIN,YMAX: draw goal centres from this table region (metres, within "
                 "-0.25,0.25,-0.1,0.4, sides >= 0.1); default the whole table "
                 "-0.2,0.2,-0.05,0.35");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help is a ParseError too
  }
  wm::InitLogging("info");
  if (look == "plain") opts.look = wm::tabletop::LookVariation::kPlain;
  try {
    if (!goal_region.empty()) opts.goal_region = wm::tabletop::ParseGoalRegion(goal_region);
    opts.Check();
    spdlog::info("generating {} train + {} val episodes ({}x{} px, up to {} steps) into {}",
                 opts.train_episodes, opts.val_episodes, opts.size, opts.size, opts.max_steps,
                 opts.out_dir);
    const wm::tabletop::TabletopSummary s = wm::tabletop::WriteTabletopDataset(opts);
    for (const auto& [policy, counts] : s.by_policy) {
      spdlog::info("policy {}: {} of {} episodes reached the goal", policy, counts.second,
                   counts.first);
    }
    spdlog::info("wrote {} episodes, {} steps, {:.1f} MB to {}", s.episodes, s.steps,
                 static_cast<double>(s.bytes) / 1e6, s.dataset_dir);
  } catch (const std::exception& e) {
    std::cerr << "wm-gen-tabletop: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

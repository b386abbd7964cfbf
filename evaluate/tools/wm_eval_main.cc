// wm-eval: roll out trained world models against held-out episodes and score them
// (docs/reports.md). Exit codes: 0 success, 1 a wmkit error (named file), 2 bad command line.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <iostream>

#include "core/cli_parse.h"
#include "core/log.h"
#include "core/malloc_tuning.h"
#include "core/provenance.h"
#include "evaluate/evaluator.h"
#include "policy/policy_spec.h"

namespace {
constexpr const char* kFooter = R"(
Example:
  wm-eval --checkpoint runs/dyn-tiny --tokenizer runs/tok-tiny \
    --data data/tabletop/val --tokens data/tabletop-tokens/val --out reports/

Writes REPORT_DIR/<checkpoint name>/{summary,per_step,per_episode,values,contexts}.csv,
manifest.json, videos/episode_K.mp4 (real | plain | retrace | error) and strips/episode_K.png
(rows real, plain, retrace, copy_last, tokenizer_recon, error; columns steps). Rollouts start from
each episode's real first frame and follow its logged actions (open loop); baselines copy_last
(the first real frame repeated), copy_last_tokens (its tokens, decoded, repeated) and
tokenizer_recon (the tokenizer's reconstruction of the true frames: the ceiling) are scored in
the same run. Controllability: the plain rollout is imagined again with the episode's actions
reversed (--controllability shuffled: seeded shuffle; off: skip) and scored as metric
delta_tpsnr = PSNR minus the perturbed rollout's PSNR (Genie's ΔtPSNR; 0 for a model that
ignores its actions, and for the copies).
Compare checkpoints with `wm-report compare`.
Uncertainty without ensembles (--retrace-ks 0,1,3; token models, end-effector-delta actions):
every step t of the plain rollout is imagined again from the real frame 0, the newest K imagined
frames and one retrace action for the older steps, once per K (the step's own seed); the
variants' mean pairwise lpips_style is retrace_disagreement, the mean entropy (nats) of the step's
token distributions token_entropy. Writes uncertainty.csv (per episode and step, beside the MSE
and, with --samples >= 2, the samples' disagreement) and summary rows <signal>_error_pearson,
_error_spearman and _auroc (flagging episodes whose mean MSE is above the median).
Motion checkpoints (wm-motion train) are scored beside token ones in the same format: the plain
rollout only, imagined from the real first frame under the logged actions (retrace skipped, with
a warning when asked for), once (deterministic), with delta_tpsnr; no values.csv or contexts.csv
rows (no reward head, no token window).
Closed loop (--policy / --policies; docs/reports.md, "Policy evaluation in the world model"): each
policy (a process speaking docs/policy-protocol.md) acts on the imagined frames from the real first
frame of each of the first --episodes held-out episodes, for --policy-horizon steps or until the
reward head says success (reward > 0.5) or the terminal head says done; --policy-rollouts per
start; --policy-batch starts imagined together in lockstep (one model call per step). A motion checkpoint has no reward head: pass --success-model RUN_DIR (wm-success train, a
classifier trained on real frames), and a step whose imagined frame it gives P(success) > 0.5 is
a success (docs/success.md); with a token checkpoint it replaces the reward head the same way. Writes wm_values.csv (success rate, Wilson 95%), wm_episodes.csv,
strips/episode_K.png and, with --true-values (wm-sim-policy's policy_values.json), wpe.csv and
wpe_summary.json; no open-loop scores. Example:
  wm-eval --checkpoint runs/dyn-tiny --tokenizer runs/tok-tiny --data data/tabletop/val \
    --tokens data/tabletop-tokens/val --out reports/ --episodes 16 \
    --policies configs/policies/tabletop.yaml --true-values truth/policy_values.json
  wm-eval --checkpoint runs/motion --success-model runs/success --tokenizer runs/tok-tiny ...
Sharded (e.g. a Slurm array): --shard-index $SLURM_ARRAY_TASK_ID --num-shards N in every job;
each writes REPORT_DIR/<name>/parts/, and the job that completes the set writes the report,
byte-identical to a single job's. Rerunning a job whose part exists only retries the report.
Exit codes: 0 success, 1 error (one line naming the file), 2 bad command line.)";

struct PolicyArgs {
  std::vector<std::string> specs, in_distribution;
  std::string list, clamp = "tabletop";
};

void AddPolicyOptions(CLI::App& app, PolicyArgs& a, wm::evaluate::PolicyEvalOptions& p) {
  app.add_option("--policy", a.specs,
                 "Closed loop: NAME=COMMAND or a policy list .yaml (repeatable)");
  app.add_option("--policies", a.list, "Closed loop: a policy list (configs/policies/*.yaml)")
      ->check(CLI::ExistingFile);
  app.add_option("--in-distribution", a.in_distribution,
                 "Names of --policy policies close to the training data's policies")
      ->delimiter(',');
  app.add_option("--policy-horizon", p.loop.horizon,
                 "Policy steps per closed-loop episode at most (wm-sim-policy --max-steps)")
      ->capture_default_str();
  app.add_option("--policy-rollouts", p.loop.rollouts, "Closed-loop rollouts per start")
      ->capture_default_str();
  app.add_option("--policy-batch", p.loop.batch,
                 "Closed-loop starts imagined together as one batch (frames equal to one at a "
                 "time up to float rounding)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_flag("--rolling-cache", p.loop.rolling_cache,
               "Closed loop of token models with rotary time (model.temporal_positions rope): keep "
               "each frame's temporal keys/values as the window slides (faster; the same frames "
               "until the window slides, its own semantics after: docs/reports.md)");
  app.add_option("--clamp-actions", a.clamp, "tabletop (the simulator's limits) or none")
      ->check(CLI::IsMember({"tabletop", "none"}))
      ->capture_default_str();
  app.add_option("--true-values", p.true_values,
                 "wm-sim-policy's policy_values.json: writes wpe.csv and wpe_summary.json")
      ->check(CLI::ExistingFile);
  app.add_option("--success-model", p.success_model,
                 "Closed loop: wm-success train's RUN_DIR, whose P(success | imagined frame) > "
                 "0.5 is a success (needed by motion checkpoints; replaces a token model's "
                 "reward head)")
      ->check(CLI::ExistingPath);
  app.add_option("--policy-timeout", p.step_timeout_s, "Seconds a policy may take per answer")
      ->capture_default_str();
  app.add_option("--policy-start-timeout", p.start_timeout_s,
                 "Seconds a policy may take to start (its hello)")
      ->capture_default_str();
}

// Open loop, or closed loop when policies are named; the report directories written.
std::vector<std::string> Evaluate(wm::evaluate::EvalOptions& o, const PolicyArgs& a) {
  if (a.specs.empty() && a.list.empty()) return wm::evaluate::EvaluateCheckpoints(o);
  o.policy_eval.policies = wm::policy::CollectPolicies(a.list, a.specs, a.in_distribution);
  o.policy_eval.loop.clamp_tabletop = a.clamp == "tabletop";
  o.policy_eval.loop.imagination = o.rollout;
  return wm::evaluate::EvaluatePolicies(o);
}

}  // namespace

int main(int argc, char** argv) {
  wm::KeepLargeAllocationsInHeap();
  wm::evaluate::EvalOptions o;
  std::string rollout = "auto", controllability = "reversed";
  CLI::App app{"wm-eval: open-loop rollouts of world-model checkpoints, scored per step"};
  app.footer(kFooter);
  app.set_version_flag("--version", wm::VersionString("wm-eval"));
  app.add_option("--checkpoint", o.checkpoints,
                 "wm-train or wm-motion run directories (one report each)")
      ->required()
      ->check(CLI::ExistingPath);
  app.add_option("--name", o.names, "Report names (default: run directory names)");
  app.add_option("--tokenizer", o.tokenizer, "The tokenizer run that wrote --tokens")
      ->required()
      ->check(CLI::ExistingPath);
  app.add_option("--data", o.data_dir, "Held-out shard dataset")
      ->required()
      ->check(CLI::ExistingDirectory);
  app.add_option("--tokens", o.tokens_dir, "The same episodes as a token dataset")
      ->required()
      ->check(CLI::ExistingDirectory);
  app.add_option("--out", o.out_dir, "REPORT_DIR")->required();
  app.add_option("--horizon", o.rollout.horizon, "Imagined frames per episode")
      ->capture_default_str();
  app.add_option("--context", o.rollout.context, "Context frames (0: the model's maximum)")
      ->capture_default_str();
  app.add_option("--rollout", rollout,
                 "plain, retrace, both, or auto: both for end-effector-delta actions, else plain "
                 "(retrace sums end-effector deltas, WHALE eq. 6)")
      ->check(CLI::IsMember({"plain", "retrace", "both", "auto"}))
      ->capture_default_str();
  app.add_option("--controllability", controllability,
                 "delta_tpsnr: plain again with the episode's actions reversed or shuffled, or off")
      ->check(CLI::IsMember({"reversed", "shuffled", "off"}))
      ->capture_default_str();
  app.add_option("--samples", o.rollout.samples, "Imaginations per episode (>= 2: uncertainty)")
      ->capture_default_str();
  app.add_option("--retrace-ks", o.retrace_ks,
                 "Uncertainty without ensembles (WHALE 3.4): K,K,... kept imagined frames after "
                 "the real frame 0; every plain step is imagined again per K, scored as "
                 "retrace_disagreement and token_entropy, written to uncertainty.csv")
      ->delimiter(',');
  app.add_option("--seed", o.rollout.seed, "Sampling and bootstrap seed")->capture_default_str();
  app.add_option("--temperature", o.rollout.temperature,
                 "MaskGIT sampling temperature (0: argmax; default: the checkpoint's)");
  app.add_option("--decode-steps", o.rollout.decode_steps,
                 "MaskGIT rounds per frame (default: the checkpoint's)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--policy-prefix", o.rollout.policy_prefix,
                 "Real frames the prior sees to infer the policy embedding")
      ->capture_default_str();
  app.add_option("--episodes", o.max_episodes, "Evaluate the first N episodes (0: all)")
      ->capture_default_str();
  app.add_option("--resamples", o.resamples, "Bootstrap replicates")->capture_default_str();
  app.add_option("--videos", o.videos, "Side-by-side MP4s of the first N episodes")
      ->capture_default_str();
  app.add_option("--strips", o.strips, "PNG strips (real above rollouts) of the first N episodes")
      ->capture_default_str();
  app.add_option("--save-rollouts", o.save_rollouts,
                 "Also write every scored episode's frames as image folders under DIR/<name>/");
  app.add_option("--masks", o.masks.source,
                 "Segmented-region MSE: none, files (--seg-config labels), motion or depth")
      ->check(CLI::IsMember({"none", "files", "motion", "depth"}))
      ->capture_default_str();
  app.add_option("--seg-config", o.masks.seg_config,
                 "Label map and mask options (configs/segmentation/*.yaml)")
      ->check(CLI::ExistingFile);
  app.add_option("--intrinsics", o.masks.intrinsics,
                 "Depth camera fx,fy,cx,cy at the shard resolution (--masks depth)");
  app.add_option("--lpips-weights", o.lpips_weights,
                 "Official LPIPS weights (scripts/export_lpips_weights.py): adds metric lpips")
      ->check(CLI::ExistingFile);
  app.add_option("--device", o.device, "cpu, cuda or cuda:N")->capture_default_str();
  app.add_option("--threads", o.threads, "LibTorch intra-op threads")->capture_default_str();
  app.add_option("--shard-index", o.shard_index, "This job's shard (Slurm array task id)")
      ->capture_default_str();
  app.add_option("--num-shards", o.num_shards, "Jobs sharing the episodes")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  PolicyArgs policy_args;
  AddPolicyOptions(app, policy_args, o.policy_eval);
  if (const int rc = wm::ParseCommandLine(app, argc, argv); rc >= 0) return rc;
  wm::InitLogging();
  using wm::evaluate::RolloutMode;
  if (rollout == "plain") o.modes = {RolloutMode::kPlain};
  if (rollout == "retrace") o.modes = {RolloutMode::kRetrace};
  o.controllability = wm::evaluate::ParsePerturbation(controllability);
  try {
    if (rollout == "auto") o.modes = wm::evaluate::AutoRolloutModes(o.tokens_dir);
    o.rollout_auto = rollout == "auto";
    for (const auto& dir : Evaluate(o, policy_args)) {
      spdlog::info("wrote {}", dir);
    }
  } catch (const std::exception& e) {
    std::cerr << "wm-eval: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

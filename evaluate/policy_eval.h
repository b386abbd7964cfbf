#pragma once
// wm-eval --policy: every policy rolled out closed loop inside each checkpoint's world model from
// the real first frames of the held-out episodes (evaluate/closed_loop.h), its value estimated as
// the model's success rate, and, given the simulator's true values, the WPE report
// (evaluate/wpe_report.h). Writes into REPORT_DIR/<checkpoint name>/ (docs/reports.md, "Policy
// evaluation in the world model"): wm_episodes.csv, wm_values.csv, strips/episode_K.png,
// wpe.csv + wpe_summary.json with --true-values, and manifest.json last, so a run that fails
// (a policy crashes, hangs or answers nonsense) leaves no report that looks finished.
#include <string>
#include <vector>

#include "evaluate/closed_loop.h"
#include "policy/policy_spec.h"

namespace wm::evaluate {

struct EvalOptions;

struct PolicyEvalOptions {
  std::vector<policy::PolicySpec> policies;  // empty: wm-eval's open-loop evaluation
  ClosedLoopOptions loop;
  std::string true_values;  // wm-sim-policy's policy_values.json; empty: no WPE report
  // wm-success train's RUN_DIR (or checkpoint.wmt): the success classifier that scores a motion
  // checkpoint's imagined frames (a motion model has no reward head); required for motion
  // checkpoints, unused by token ones, which have their reward head.
  std::string success_model;
  double step_timeout_s = 30;   // per policy answer
  double start_timeout_s = 60;  // for the policy's hello
};

// Runs every policy of options.policy_eval in every checkpoint of `options` (its data, tokens,
// tokenizer, episodes, seed, context, temperature, decode steps, strips, threads and device): a
// token checkpoint's reward head, or for a motion checkpoint the success classifier
// policy_eval.success_model, says when an episode succeeds.
// Returns the report directories written. Throws wm::Error naming the policy, episode and step
// when a policy fails, after removing the report's finished-looking files.
std::vector<std::string> EvaluatePolicies(const EvalOptions& options);

}  // namespace wm::evaluate

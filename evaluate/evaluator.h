#pragma once
// wm-eval's work: roll out every held-out episode with each checkpoint (plain and retracing),
// decode, score against the real frames with the baselines beside them, and write the report
// directory of each checkpoint (docs/reports.md).
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "evaluate/controllability.h"
#include "evaluate/policy_eval.h"
#include "evaluate/region_masks.h"
#include "evaluate/rollout.h"

namespace wm::evaluate {

struct EvalOptions {
  // wm-train (token dynamics) or wm-motion (motion model, plain rollout only) run directories or
  // checkpoint.wmt files
  std::vector<std::string> checkpoints;
  std::vector<std::string> names;  // report names, default: the run directory names
  std::string tokenizer;           // the tokenizer that wrote `tokens_dir`
  std::string data_dir;            // the held-out shard dataset (real frames, rewards)
  std::string tokens_dir;          // the same episodes as a token dataset
  std::string out_dir;             // REPORT_DIR
  std::vector<RolloutMode> modes = {RolloutMode::kPlain, RolloutMode::kRetrace};
  // `modes` came from --rollout auto (the data's action space), not the user: a motion checkpoint,
  // which has no retrace rollout, then drops retrace without a warning.
  bool rollout_auto = false;
  RolloutOptions rollout;
  // Controllability (metric delta_tpsnr of the plain rollout; 0 for the copy baselines): the
  // plain rollout again with the episode's actions perturbed; kOff skips it. Only when the plain
  // rollout is evaluated.
  Perturbation controllability = Perturbation::kReversed;
  // Uncertainty without ensembles (WHALE section 3.4; evaluate/retrace_uncertainty.h): kept-frame
  // counts k of the retracing variants imagined at every step of the plain rollout; empty = off.
  // When set, the plain rollout also gets metrics retrace_disagreement and token_entropy, and
  // the report uncertainty.csv and the signals' correlations and AUROCs (docs/reports.md).
  std::vector<int64_t> retrace_ks;
  MaskOptions masks;          // segmented-region MSE (mse_arm, mse_object, mse_background) when set
  std::string lpips_weights;  // official LPIPS (metric "lpips") besides lpips_style when set
  int64_t max_episodes = 0;   // 0 = every episode
  int resamples = 1000;       // bootstrap replicates for every interval
  int videos = 2;             // side-by-side MP4s of the first episodes
  int strips = 4;             // PNG strips (evaluate/episode_strip.h) of the first episodes
  std::string save_rollouts;  // export every scored episode's frames here (rollout_export.h)
  std::string device = "cpu";
  int threads = 1;
  bool show_progress = true;
  // Slurm-array style sharding: this job scores every num_shards-th episode from shard_index,
  // writes REPORT_DIR/<name>/parts/part-<i>-of-<n>.json, and the job that completes the set
  // writes the report, identical to a single job's. A part already there is not redone.
  int shard_index = 0, num_shards = 1;
  // Closed-loop policy evaluation (wm-eval --policy) instead of open-loop rollouts when it names
  // policies; `rollout` gives its context, seed, temperature and decode steps.
  PolicyEvalOptions policy_eval;
};

// Returns the report directories written (one per checkpoint; none from a shard job that leaves
// parts missing). Throws wm::Error naming the file when the tokenizer, token data and shard data
// do not belong together, or a part belongs to another run.
std::vector<std::string> EvaluateCheckpoints(const EvalOptions& options);

// The model of `checkpoint` for `data`: raw actions are normalised with the statistics of the
// data's dataset when the model was trained on it (one of a mixture, maybe narrower than the
// model), else with those of its first dataset.
std::unique_ptr<train::DynamicsModel> LoadModelFor(const EvalOptions& options,
                                                   const std::string& checkpoint,
                                                   const tokens::TokenDataset& data);

}  // namespace wm::evaluate

#pragma once
// wm-sim-policy's library entry: the true values of policies in the tabletop world. Each policy
// (a process speaking the wmkit-policy protocol, docs/policy-protocol.md) runs closed loop on
// the episodes wm-gen-tabletop starts from the same seed and split, seeing exactly the frames
// the dataset stores. Writes (docs/sim-policy.md):
//   <out>/policy_values.json, policy_values.csv   one row per policy: success rate = true value,
//                                                 Wilson 95% interval, mean return and steps
//   <out>/policy_episodes.csv                     one row per policy and episode
//   <out>/<name>/<version>/                       the episodes as an RLDS dataset, one split
//                                                 per policy (like wm-gen-tabletop's)
// Same options and policies -> identical bytes. A policy failure stops the run with its error,
// and no summary or dataset_info.json is left that looks finished.
#include <cstdint>
#include <string>
#include <vector>

#include "ingest/tabletop/scene.h"
#include "policy/policy_spec.h"

namespace wm::tabletop {

struct SimPolicyOptions {
  std::string out_dir;                       // required
  std::vector<policy::PolicySpec> policies;  // at least one; names are the splits
  int episodes = 50;          // episodes per policy: indices 0..episodes-1 of `split`
  int max_steps = 40;         // horizon (steps per episode at most), 1..1000
  int size = 128;             // image side in pixels, 64..256 (wm-gen-tabletop's --size)
  uint64_t seed = 0;          // wm-gen-tabletop's --seed: with `split`, fixes every episode
  std::string split = "val";  // whose episode seeds (layouts, looks, instructions) to use
  LookVariation look = LookVariation::kVaried;  // wm-gen-tabletop's --look
  std::string name = "wm_tabletop_sim";         // the RLDS dataset's TFDS name
  std::string version = "1.0.0";                // its TFDS version
  bool write_dataset = true;                    // false: summaries only (faster)
  double step_timeout_s = 30;                   // per policy answer
  double start_timeout_s = 60;                  // for the policy's hello
  void Check() const;                           // throws wm::Error naming the offending flag
};

struct PolicyTruth {
  policy::PolicySpec spec;
  int episodes = 0, successes = 0;
  double true_value = 0, ci_low = 0, ci_high = 0;  // success rate, Wilson 95%
  double mean_return = 0;
  double mean_steps = 0;  // steps per episode, terminal step included
};

// Runs every policy on every episode and writes the outputs above.
std::vector<PolicyTruth> RunSimPolicies(const SimPolicyOptions& options);

}  // namespace wm::tabletop

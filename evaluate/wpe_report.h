#pragma once
// The WPE report (wpe-policy-evaluation.txt Sec. 5, issue 21 item 5): per policy the true value
// from the simulator (wm-sim-policy's policy_values.json) beside the world model's estimate, and
// across policies how well the estimates rank and match the truth. Files (docs/reports.md,
// "Policy evaluation"): wpe.csv (schemas/wpe-row.schema.json) and wpe_summary.json
// (schemas/wpe-summary.schema.json).
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace wm::evaluate {

// One policy's value with its interval (a success rate with its Wilson 95% interval).
struct PolicyEstimate {
  std::string policy;
  bool in_distribution = false;
  int64_t episodes = 0;
  double value = 0, ci_low = 0, ci_high = 0;
};

// The policies of wm-sim-policy's policy_values.json. Throws wm::Error naming the file and field.
std::vector<PolicyEstimate> ReadTrueValues(const std::string& path);

struct WpeRow {
  PolicyEstimate truth, model;
  double gap = 0;  // model - truth: > 0 when the model overrates the policy
};

struct WpeSummary {
  int64_t num_policies = 0;
  // Across policies, between true and model values (metrics/value: SciPy's definitions; NaN,
  // written as null, when undefined, e.g. every model value equal).
  double spearman = 0, kendall = 0, pairwise_accuracy = 0;
  double mean_abs_gap = 0;
  // Mean signed gap (model - truth) over all, in-distribution and out-of-distribution policies
  // (WPE found under-estimation in distribution, over-estimation out of it). NaN for none.
  double optimism = 0, optimism_in_distribution = 0, optimism_out_of_distribution = 0;
  int64_t num_in_distribution = 0;
};

// Pairs every model estimate with the true value of the policy of the same name (in `model`'s
// order). Throws wm::Error(file `truth_file`) for a policy the truth does not have.
std::vector<WpeRow> PairWithTruth(const std::vector<PolicyEstimate>& model,
                                  const std::vector<PolicyEstimate>& truth,
                                  const std::string& truth_file);

WpeSummary SummarizeWpe(const std::vector<WpeRow>& rows);

// Writes DIR/wpe.csv, then DIR/wpe_summary.json (with `provenance`), atomically.
void WriteWpeReport(const std::string& dir, const std::vector<WpeRow>& rows,
                    const WpeSummary& summary, const nlohmann::json& provenance);

}  // namespace wm::evaluate

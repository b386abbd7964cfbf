#pragma once
// Value metrics: how well returns imagined in a world model stand in for real returns, per
// policy and for ranking policies (WHALE-X §2 "value gap"; WPE §5 policy ranking). Input is one
// row per episode: the episode's return in the real environment and the return of the same
// episode replayed in the model (same policy, same initial state). Definitions, tie rules,
// the bootstrap scheme and undefined cases: docs/metrics-value.md.
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "metrics/value/bootstrap.h"

namespace wm::metrics {

struct EpisodeReturn {
  std::string episode;    // identifier; unique within its policy
  std::string policy_id;  // non-empty
  double real_return;     // return in the real environment (finite)
  double model_return;    // return of the episode's rollout in the world model (finite)
};

// One metric: its value on all episodes and its bootstrap percentile interval.
struct Estimate {
  static constexpr double kUndefined = std::numeric_limits<double>::quiet_NaN();
  double value = kUndefined;   // NaN: undefined (e.g. a correlation of constant values)
  double ci_low = kUndefined;  // NaN without resamples or when no replicate is defined
  double ci_high = kUndefined;
  int64_t resamples_defined = 0;  // replicates in which the metric was defined (not NaN)
};

// V = mean return over the policy's episodes (WHALE-X eq. 1, estimated by Monte Carlo).
struct PolicyValue {
  std::string policy_id;
  int64_t episodes = 0;
  Estimate real_value;   // V_real
  Estimate model_value;  // V_model
  Estimate value_gap;    // |V_real - V_model|
  Estimate optimism;     // V_model - V_real: > 0 when the model overrates the policy
};

struct Correlations {
  Estimate pearson;
  Estimate spearman;       // average ranks for ties
  Estimate kendall_tau_b;  // scipy.stats.kendalltau's default variant
};

struct ValueMetrics {
  int64_t episodes = 0;
  std::vector<PolicyValue> policies;  // sorted by policy_id (byte order)

  Estimate value_gap;             // mean over policies of |V_real - V_model|
  Estimate normalized_value_gap;  // value_gap / (max - min of V_real); undefined when that is 0
  Estimate optimism;              // mean over policies of V_model - V_real

  // Ranking across policies, between the V_real and V_model of each policy; undefined with
  // fewer than 2 policies.
  Correlations policy_correlation;
  Estimate top1_agreement;     // see Top1Agreement
  Estimate pairwise_accuracy;  // see PairwiseAccuracy

  // Between real_return and model_return across all episodes (of every policy).
  Correlations episode_correlation;

  BootstrapOptions bootstrap;  // as used
};

// Every metric with its interval. Episodes are grouped by policy_id; the bootstrap resamples
// episodes with replacement within each policy (stratified), so every replicate keeps every
// policy and its episode count. Throws wm::Error for no episodes, an empty policy_id, a
// non-finite return, or an episode listed twice for one policy.
ValueMetrics ComputeValueMetrics(const std::vector<EpisodeReturn>& episodes,
                                 const BootstrapOptions& options);

// The chance that a uniform pick among the policies with the highest model value is one of the
// policies with the highest real value: |best_real ∩ best_model| / |best_model|. 1 or 0 without
// ties. Ties are exact equality. NaN for fewer than 2 policies.
double Top1Agreement(const std::vector<double>& real, const std::vector<double>& model);

// Over the policy pairs whose real values differ: the fraction the model orders the same way,
// a pair the model ties counting 1/2. Pairs tied in reality have no true order and are left
// out. NaN for fewer than 2 policies or when every pair is tied in reality.
double PairwiseAccuracy(const std::vector<double>& real, const std::vector<double>& model);

}  // namespace wm::metrics

#include "metrics/value/value_metrics.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <set>

#include "core/error.h"
#include "metrics/value/correlation.h"

namespace wm::metrics {
namespace {

constexpr double kNaN = Estimate::kUndefined;

// One policy's episodes, real and model returns paired by index.
struct PolicyGroup {
  std::string policy_id;
  std::vector<double> real, model;
};

double Mean(const std::vector<double>& v) {
  return std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

double MeanOf(const std::vector<PolicyValue>& policies, Estimate PolicyValue::*field) {
  double sum = 0;
  for (const auto& p : policies) sum += (p.*field).value;
  return sum / static_cast<double>(policies.size());
}

std::vector<PolicyGroup> GroupByPolicy(const std::vector<EpisodeReturn>& episodes) {
  Check(!episodes.empty(), "no episodes: value metrics need at least one");
  std::map<std::string, PolicyGroup> groups;  // sorted by policy_id
  std::set<std::pair<std::string, std::string>> seen;
  for (size_t i = 0; i < episodes.size(); ++i) {
    const EpisodeReturn& e = episodes[i];
    const ErrorContext where{.record = static_cast<int64_t>(i), .record_label = "episode row"};
    Check(!e.policy_id.empty(), "empty policy_id", where);
    Check(std::isfinite(e.real_return) && std::isfinite(e.model_return),
          "episode '" + e.episode + "' of policy '" + e.policy_id + "' has a non-finite return",
          where);
    Check(seen.emplace(e.policy_id, e.episode).second,
          "episode '" + e.episode + "' of policy '" + e.policy_id + "' is listed twice", where);
    PolicyGroup& g = groups[e.policy_id];
    g.policy_id = e.policy_id;
    g.real.push_back(e.real_return);
    g.model.push_back(e.model_return);
  }
  std::vector<PolicyGroup> out;
  out.reserve(groups.size());
  for (auto& [id, group] : groups) out.push_back(std::move(group));
  return out;
}

void FillCorrelations(const std::vector<double>& x, const std::vector<double>& y, Correlations& c) {
  c.pearson.value = Pearson(x, y);
  c.spearman.value = Spearman(x, y);
  c.kendall_tau_b.value = KendallTauB(x, y);
}

// The point estimates (Estimate::value) of every metric on one set of episodes.
ValueMetrics PointMetrics(const std::vector<PolicyGroup>& groups) {
  ValueMetrics m;
  std::vector<double> real_values, model_values, all_real, all_model;
  for (const PolicyGroup& g : groups) {
    PolicyValue p{.policy_id = g.policy_id, .episodes = static_cast<int64_t>(g.real.size())};
    p.real_value.value = Mean(g.real);
    p.model_value.value = Mean(g.model);
    p.value_gap.value = std::abs(p.real_value.value - p.model_value.value);
    p.optimism.value = p.model_value.value - p.real_value.value;
    real_values.push_back(p.real_value.value);
    model_values.push_back(p.model_value.value);
    all_real.insert(all_real.end(), g.real.begin(), g.real.end());
    all_model.insert(all_model.end(), g.model.begin(), g.model.end());
    m.episodes += p.episodes;
    m.policies.push_back(std::move(p));
  }
  m.value_gap.value = MeanOf(m.policies, &PolicyValue::value_gap);
  m.optimism.value = MeanOf(m.policies, &PolicyValue::optimism);
  const auto [lo, hi] = std::minmax_element(real_values.begin(), real_values.end());
  // A zero range (one policy, or equal real values) leaves nothing to normalise by.
  m.normalized_value_gap.value = *hi > *lo ? m.value_gap.value / (*hi - *lo) : kNaN;
  FillCorrelations(real_values, model_values, m.policy_correlation);
  m.top1_agreement.value = Top1Agreement(real_values, model_values);
  m.pairwise_accuracy.value = PairwiseAccuracy(real_values, model_values);
  FillCorrelations(all_real, all_model, m.episode_correlation);
  return m;
}

void AddCorrelations(Correlations& c, std::vector<Estimate*>& out) {
  out.insert(out.end(), {&c.pearson, &c.spearman, &c.kendall_tau_b});
}

// Every Estimate of `m` in a fixed order, so replicate k's metric i lines up with the point
// estimate's metric i.
std::vector<Estimate*> AllEstimates(ValueMetrics& m) {
  std::vector<Estimate*> out = {&m.value_gap, &m.normalized_value_gap, &m.optimism,
                                &m.top1_agreement, &m.pairwise_accuracy};
  AddCorrelations(m.policy_correlation, out);
  AddCorrelations(m.episode_correlation, out);
  for (PolicyValue& p : m.policies) {
    out.insert(out.end(), {&p.real_value, &p.model_value, &p.value_gap, &p.optimism});
  }
  return out;
}

std::vector<PolicyGroup> Resample(const std::vector<PolicyGroup>& groups,
                                  const std::vector<std::vector<size_t>>& draws) {
  std::vector<PolicyGroup> out(groups.size());
  for (size_t g = 0; g < groups.size(); ++g) {
    out[g].policy_id = groups[g].policy_id;
    for (size_t index : draws[g]) {
      out[g].real.push_back(groups[g].real[index]);
      out[g].model.push_back(groups[g].model[index]);
    }
  }
  return out;
}

// Sets every interval of `m` from `options.resamples` stratified replicates.
void AddIntervals(const std::vector<PolicyGroup>& groups, const BootstrapOptions& options,
                  ValueMetrics& m) {
  const std::vector<Estimate*> estimates = AllEstimates(m);
  std::vector<std::vector<double>> replicates(estimates.size());
  for (auto& r : replicates) r.reserve(static_cast<size_t>(options.resamples));
  std::vector<size_t> sizes;
  for (const auto& g : groups) sizes.push_back(g.real.size());
  std::mt19937_64 rng(options.seed);
  for (int b = 0; b < options.resamples; ++b) {
    ValueMetrics replicate = PointMetrics(Resample(groups, DrawStratified(sizes, rng)));
    const std::vector<Estimate*> values = AllEstimates(replicate);
    for (size_t i = 0; i < values.size(); ++i) replicates[i].push_back(values[i]->value);
  }
  for (size_t i = 0; i < estimates.size(); ++i) {
    const Interval ci = PercentileInterval(std::move(replicates[i]), options.level);
    estimates[i]->ci_low = ci.low;
    estimates[i]->ci_high = ci.high;
    estimates[i]->resamples_defined = ci.defined;
  }
}

}  // namespace

ValueMetrics ComputeValueMetrics(const std::vector<EpisodeReturn>& episodes,
                                 const BootstrapOptions& options) {
  options.Check();
  const std::vector<PolicyGroup> groups = GroupByPolicy(episodes);
  ValueMetrics m = PointMetrics(groups);
  m.bootstrap = options;
  if (options.resamples > 0) AddIntervals(groups, options, m);
  return m;
}

double Top1Agreement(const std::vector<double>& real, const std::vector<double>& model) {
  if (real.size() < 2) return kNaN;
  const double best_real = *std::max_element(real.begin(), real.end());
  const double best_model = *std::max_element(model.begin(), model.end());
  int model_best = 0, both_best = 0;
  for (size_t i = 0; i < real.size(); ++i) {
    if (model[i] != best_model) continue;
    ++model_best;
    both_best += real[i] == best_real;
  }
  return static_cast<double>(both_best) / model_best;
}

double PairwiseAccuracy(const std::vector<double>& real, const std::vector<double>& model) {
  double score = 0;
  int pairs = 0;
  for (size_t i = 0; i < real.size(); ++i) {
    for (size_t j = i + 1; j < real.size(); ++j) {
      if (real[i] == real[j]) continue;
      ++pairs;
      const double true_sign = real[i] < real[j] ? 1 : -1;
      const double model_diff = (model[j] - model[i]) * true_sign;
      score += model_diff > 0 ? 1.0 : model_diff == 0 ? 0.5 : 0.0;
    }
  }
  return pairs == 0 ? kNaN : score / pairs;
}

}  // namespace wm::metrics

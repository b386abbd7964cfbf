// Value metrics on cases worked out by hand: value gap, optimism, ranking with ties, the
// bootstrap's determinism and coverage, and degenerate inputs. test_value_reference.py checks
// the same code through wm-metrics against SciPy/NumPy.
#include "metrics/value/value_metrics.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "metrics/value/value_io.h"
#include "tests/core/test_util.h"

namespace wm::metrics {
namespace {

using ::testing::HasSubstr;

// Policies a, b, c with two episodes each; V_real = 1, 0.5, 0 and V_model = 0.75, 0.75, 0.25.
std::vector<EpisodeReturn> ThreePolicies() {
  return {{"0", "a", 1.0, 0.5}, {"1", "a", 1.0, 1.0}, {"0", "b", 0.0, 1.0},
          {"1", "b", 1.0, 0.5}, {"0", "c", 0.0, 0.5}, {"1", "c", 0.0, 0.0}};
}

// `policies` policies of `episodes` episodes; the model tracks reality with noise and a bias.
std::vector<EpisodeReturn> NoisyReturns(int policies, int episodes, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0, 1);
  std::vector<EpisodeReturn> rows;
  for (int p = 0; p < policies; ++p) {
    for (int e = 0; e < episodes; ++e) {
      const double real = p + noise(rng);
      rows.push_back({std::to_string(e), "policy" + std::to_string(p), real,
                      0.8 * real + 0.3 + 0.5 * noise(rng)});
    }
  }
  return rows;
}

BootstrapOptions NoBootstrap() { return {.resamples = 0}; }

TEST(ValueMetrics, ValueGapAndOptimismByHand) {
  const ValueMetrics m = ComputeValueMetrics(ThreePolicies(), NoBootstrap());
  ASSERT_EQ(m.policies.size(), 3u);
  EXPECT_EQ(m.episodes, 6);
  EXPECT_EQ(m.policies[0].policy_id, "a");
  EXPECT_EQ(m.policies[0].episodes, 2);
  EXPECT_DOUBLE_EQ(m.policies[0].real_value.value, 1.0);
  EXPECT_DOUBLE_EQ(m.policies[0].model_value.value, 0.75);
  EXPECT_DOUBLE_EQ(m.policies[0].value_gap.value, 0.25);
  EXPECT_DOUBLE_EQ(m.policies[0].optimism.value, -0.25);
  EXPECT_DOUBLE_EQ(m.policies[1].optimism.value, 0.25);
  EXPECT_DOUBLE_EQ(m.policies[2].optimism.value, 0.25);
  EXPECT_DOUBLE_EQ(m.value_gap.value, 0.25);                   // (0.25 + 0.25 + 0.25) / 3
  EXPECT_DOUBLE_EQ(m.normalized_value_gap.value, 0.25 / 1.0);  // range of V_real: 1 - 0
  EXPECT_NEAR(m.optimism.value, 0.25 / 3, 1e-15);              // (-0.25 + 0.25 + 0.25) / 3
  // V_real 1 > 0.5 > 0, V_model 0.75 = 0.75 > 0.25: the model ties the two best.
  EXPECT_DOUBLE_EQ(m.top1_agreement.value, 0.5);
  EXPECT_DOUBLE_EQ(m.pairwise_accuracy.value, 2.5 / 3);
  EXPECT_NEAR(m.policy_correlation.kendall_tau_b.value, 2 / std::sqrt(3.0 * 2), 1e-15);
  EXPECT_TRUE(std::isnan(m.value_gap.ci_low));  // no resamples, no intervals
}

TEST(ValueMetrics, Top1AgreementWithTies) {
  EXPECT_EQ(Top1Agreement({3, 2, 1}, {0.9, 0.5, 0.1}), 1.0);
  EXPECT_EQ(Top1Agreement({3, 2, 1}, {0.5, 0.9, 0.1}), 0.0);
  EXPECT_EQ(Top1Agreement({3, 2, 1}, {0.9, 0.9, 0.1}), 0.5);  // 1 of the model's 2 best
  EXPECT_EQ(Top1Agreement({3, 3, 1}, {0.9, 0.9, 0.1}), 1.0);  // both are truly best
  EXPECT_EQ(Top1Agreement({3, 3, 1}, {0.1, 0.9, 0.5}), 1.0);
  EXPECT_EQ(Top1Agreement({1, 1, 1}, {0.1, 0.2, 0.3}), 1.0);  // every policy is truly best
  EXPECT_TRUE(std::isnan(Top1Agreement({1}, {2})));
}

TEST(ValueMetrics, PairwiseAccuracyWithTies) {
  EXPECT_EQ(PairwiseAccuracy({1, 2, 3}, {10, 20, 30}), 1.0);
  EXPECT_EQ(PairwiseAccuracy({1, 2, 3}, {30, 20, 10}), 0.0);
  EXPECT_EQ(PairwiseAccuracy({1, 2, 3}, {1, 1, 3}), 2.5 / 3);  // a model tie scores 1/2
  EXPECT_EQ(PairwiseAccuracy({1, 1, 2}, {2, 1, 3}), 1.0);      // the real tie is left out
  EXPECT_EQ(PairwiseAccuracy({1, 1, 2}, {1, 1, 0}), 0.0);
  EXPECT_TRUE(std::isnan(PairwiseAccuracy({5, 5, 5}, {1, 2, 3})));  // no ordered pair
  EXPECT_TRUE(std::isnan(PairwiseAccuracy({5}, {1})));
}

TEST(ValueMetrics, BootstrapIsDeterministicForASeed) {
  const auto rows = NoisyReturns(4, 12, 1);
  const BootstrapOptions options{.resamples = 300, .seed = 42};
  const nlohmann::json first = ValueMetricsToJson(ComputeValueMetrics(rows, options));
  EXPECT_EQ(first, ValueMetricsToJson(ComputeValueMetrics(rows, options)));
  BootstrapOptions other = options;
  other.seed = 43;
  const ValueMetrics changed = ComputeValueMetrics(rows, other);
  EXPECT_EQ(first["value_gap"]["value"], changed.value_gap.value);  // points do not move
  EXPECT_NE(first["value_gap"]["ci_low"], changed.value_gap.ci_low);
}

TEST(ValueMetrics, IntervalsContainThePointEstimate) {
  const ValueMetrics m = ComputeValueMetrics(NoisyReturns(5, 40, 2), {.resamples = 1000});
  const std::vector<std::pair<std::string, Estimate>> all = {
      {"value_gap", m.value_gap},
      {"optimism", m.optimism},
      {"normalized_value_gap", m.normalized_value_gap},
      {"policy pearson", m.policy_correlation.pearson},
      {"episode pearson", m.episode_correlation.pearson},
      {"episode spearman", m.episode_correlation.spearman},
      {"episode kendall", m.episode_correlation.kendall_tau_b},
      {"policy 0 model value", m.policies[0].model_value},
      {"policy 4 optimism", m.policies[4].optimism}};
  for (const auto& [name, e] : all) {
    EXPECT_LE(e.ci_low, e.value) << name;
    EXPECT_GE(e.ci_high, e.value) << name;
    EXPECT_LT(e.ci_low, e.ci_high) << name;
    EXPECT_EQ(e.resamples_defined, 1000) << name;
  }
}

TEST(ValueMetrics, ConstantReturnsGiveUndefinedCorrelationsNotErrors) {
  std::vector<EpisodeReturn> rows;
  for (const char* policy : {"a", "b", "c"}) {
    for (int e = 0; e < 3; ++e) rows.push_back({std::to_string(e), policy, 1.0, 0.5 + e});
  }
  const ValueMetrics m = ComputeValueMetrics(rows, {.resamples = 50});
  EXPECT_DOUBLE_EQ(m.value_gap.value, 0.5);
  EXPECT_TRUE(std::isnan(m.normalized_value_gap.value));  // V_real range 0
  EXPECT_TRUE(std::isnan(m.policy_correlation.pearson.value));
  EXPECT_TRUE(std::isnan(m.episode_correlation.spearman.value));
  EXPECT_TRUE(std::isnan(m.pairwise_accuracy.value));
  EXPECT_TRUE(std::isnan(m.episode_correlation.kendall_tau_b.ci_low));
  EXPECT_EQ(m.episode_correlation.kendall_tau_b.resamples_defined, 0);
  const nlohmann::json j = ValueMetricsToJson(m);
  EXPECT_TRUE(j["policy_ranking"]["pearson"]["value"].is_null());
  EXPECT_TRUE(j["normalized_value_gap"]["ci_high"].is_null());
}

TEST(ValueMetrics, OnePolicyHasNoRanking) {
  const ValueMetrics m =
      ComputeValueMetrics({{"0", "only", 1, 2}, {"1", "only", 3, 3}}, {.resamples = 20});
  EXPECT_DOUBLE_EQ(m.value_gap.value, 0.5);
  for (const Estimate* e : {&m.policy_correlation.pearson, &m.policy_correlation.spearman,
                            &m.policy_correlation.kendall_tau_b, &m.top1_agreement,
                            &m.pairwise_accuracy, &m.normalized_value_gap}) {
    EXPECT_TRUE(std::isnan(e->value));
  }
  EXPECT_DOUBLE_EQ(m.episode_correlation.pearson.value, 1.0);  // two episodes
}

TEST(ValueMetrics, BadInputIsAnError) {
  EXPECT_THAT(test::ErrorText([] { ComputeValueMetrics({}, NoBootstrap()); }),
              HasSubstr("no episodes"));
  EXPECT_THAT(test::ErrorText([] {
                ComputeValueMetrics({{"0", "", 1, 1}}, NoBootstrap());
              }),
              HasSubstr("empty policy_id"));
  EXPECT_THAT(test::ErrorText([] {
                ComputeValueMetrics({{"0", "a", 1, 1}, {"0", "a", 2, 2}}, NoBootstrap());
              }),
              HasSubstr("episode row 1: episode '0' of policy 'a' is listed twice"));
  EXPECT_THAT(test::ErrorText([] {
                ComputeValueMetrics({{"0", "a", NAN, 1}}, NoBootstrap());
              }),
              HasSubstr("non-finite"));
  EXPECT_THAT(test::ErrorText([] { ComputeValueMetrics(ThreePolicies(), {.level = 1.0}); }),
              HasSubstr("confidence level"));
}

TEST(ValueMetrics, CsvOutputHasARowPerMetric) {
  const std::string csv = ValueMetricsToCsv(ComputeValueMetrics(ThreePolicies(), NoBootstrap()));
  EXPECT_THAT(csv, HasSubstr("metric,policy_id,value,ci_low,ci_high,resamples_defined\n"));
  EXPECT_THAT(csv, HasSubstr("\nvalue_gap,,0.25,,,0\n"));
  EXPECT_THAT(csv, HasSubstr("\npolicy_ranking.top1_agreement,,0.5,,,0\n"));
  EXPECT_THAT(csv, HasSubstr("\noptimism,a,-0.25,,,0\n"));
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 1 + 11 + 3 * 4);
}

}  // namespace
}  // namespace wm::metrics

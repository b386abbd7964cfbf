// wm-eval --retrace-ks' report (evaluate/uncertainty_report.h) on hand-made episode records:
// the median split, uncertainty.csv's rows, and the signals' correlations and AUROCs worked out
// by hand; the variant pairs of evaluate/retrace_uncertainty.h.
#include "evaluate/uncertainty_report.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "evaluate/retrace_uncertainty.h"

namespace wm::evaluate {
namespace {

EpisodeRecord Record(int64_t episode, std::vector<double> mse, std::vector<double> entropy) {
  EpisodeRecord r{.episode = episode, .policy_id = "p", .steps = 2};
  r.scores["plain"]["mse"] = std::move(mse);
  r.scores["plain"]["token_entropy"] = std::move(entropy);
  return r;
}

TEST(UncertaintyReport, AboveMedianIsStrict) {
  EXPECT_EQ(AboveMedian({3, 1, 2}), (std::vector<bool>{true, false, false}));
  EXPECT_EQ(AboveMedian({4, 1, 2, 3}), (std::vector<bool>{true, false, false, true}));  // 2.5
  EXPECT_EQ(AboveMedian({1, 1, 1}), (std::vector<bool>{false, false, false}));
  EXPECT_TRUE(AboveMedian({}).empty());
}

TEST(UncertaintyReport, RowsCorrelationsAndAuroc) {
  // Episode mean MSEs 1.5, 3.5, 10 (median 3.5: only episode 2 above); mean entropies 0.15,
  // 0.35, 0.25: episode 2's ranks above episode 0's, below episode 1's -> AUROC 1/2.
  std::vector<EpisodeRecord> records = {Record(0, {1, 2}, {0.1, 0.2}),
                                        Record(1, {3, 4}, {0.3, 0.4}),
                                        Record(2, {10, 10}, {0.25, 0.25})};
  records[1].spread["plain"] = {0.5, 0.6};  // only one episode has samples: no sample rows
  ScoreTable t;
  const std::string csv = AddUncertaintyScores(t, "dyn", records);
  EXPECT_EQ(csv.substr(0, csv.find('\n')),
            "checkpoint,rollout,episode,step,mse,retrace_disagreement,token_entropy,"
            "sample_disagreement");
  EXPECT_NE(csv.find("\ndyn,plain,0,2,2,,0.2,\n"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\ndyn,plain,1,1,3,,0.3,0.5\n"), std::string::npos) << csv;
  const auto& whole = t.whole_set.at("plain");
  EXPECT_DOUBLE_EQ(whole.at("token_entropy_auroc").mean, 0.5);
  EXPECT_EQ(whole.at("token_entropy_auroc").n, 3);
  // Pairs (0.1, 1) (0.2, 2) (0.3, 3) (0.4, 4) (0.25, 10) (0.25, 10): error ranks 1 2 3 4 5.5
  // 5.5, entropy ranks 1 2 5 6 3.5 3.5.
  const double spearman = [] {
    const double x[] = {1, 2, 5, 6, 3.5, 3.5}, y[] = {1, 2, 3, 4, 5.5, 5.5};
    double sxy = 0, sxx = 0, syy = 0;
    for (int i = 0; i < 6; ++i) {
      sxy += (x[i] - 3.5) * (y[i] - 3.5), sxx += (x[i] - 3.5) * (x[i] - 3.5),
          syy += (y[i] - 3.5) * (y[i] - 3.5);
    }
    return sxy / std::sqrt(sxx * syy);
  }();
  EXPECT_NEAR(whole.at("token_entropy_error_spearman").mean, spearman, 1e-12);
  EXPECT_EQ(whole.at("token_entropy_error_spearman").n, 6);
  EXPECT_TRUE(whole.count("token_entropy_error_pearson"));
  EXPECT_FALSE(whole.count("retrace_disagreement_auroc"));
  EXPECT_FALSE(whole.count("sample_disagreement_auroc"));
}

TEST(RetraceUncertainty, VariantPairsAndKsChecks) {
  using Pairs = std::vector<std::pair<int64_t, int64_t>>;
  EXPECT_EQ(VariantPairs(3), (Pairs{{0, 1}, {0, 2}, {1, 2}}));
  EXPECT_TRUE(VariantPairs(1).empty());
  EXPECT_NO_THROW(CheckRetraceKs({0, 1, 3}, 4));
  EXPECT_THROW(CheckRetraceKs({0, 4}, 4), Error);  // frame 0 takes a slot: k <= 3
  EXPECT_THROW(CheckRetraceKs({2}, 4), Error);
  EXPECT_THROW(CheckRetraceKs({1, 1}, 4), Error);
  EXPECT_THROW(CheckRetraceKs({-1, 1}, 4), Error);
}

}  // namespace
}  // namespace wm::evaluate

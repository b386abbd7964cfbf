// wm-report compare on hand-made report directories: ranks (directions, ties), deltas against the
// baseline, paired bootstrap significance, output bytes.
#include "evaluate/report/compare.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "evaluate/report/compare_format.h"
#include "evaluate/report/metric_direction.h"
#include "report_fixture.h"
#include "tests/core/test_util.h"

namespace wm::report {
namespace {

using test::FakeReport;
using ::testing::HasSubstr;
using ::testing::Not;

std::vector<CheckpointReport> Read(const test::TempDir& tmp, const std::vector<FakeReport>& rs) {
  std::vector<CheckpointReport> reports;
  for (const auto& r : rs) {
    reports.push_back(ReadCheckpointReport(test::WriteFakeReport(tmp.path().string(), r)));
  }
  return reports;
}

// The row of `checkpoint` and `rollout`.
const ComparisonRow& Row(const Comparison& c, const std::string& checkpoint,
                         const std::string& rollout = "plain") {
  for (const auto& row : c.rows) {
    if (row.checkpoint == checkpoint && row.rollout == rollout) return row;
  }
  throw std::runtime_error("no row " + checkpoint + "/" + rollout);
}

size_t MetricIndex(const Comparison& c, const std::string& metric) {
  for (size_t i = 0; i < c.metrics.size(); ++i) {
    if (c.metrics[i] == metric) return i;
  }
  throw std::runtime_error("no metric " + metric);
}

const MetricComparison& Cell(const Comparison& c, const std::string& checkpoint,
                             const std::string& metric, const std::string& rollout = "plain") {
  return Row(c, checkpoint, rollout).metrics[MetricIndex(c, metric)];
}

TEST(Compare, RanksFollowEachMetricsDirectionAndTiesShareTheBetterRank) {
  test::TempDir tmp;
  auto reports = Read(
      tmp, {{"a", {{"plain", {{"psnr", {30, 30}}, {"mse", {0.1, 0.1}}, {"ssim", {0.5, 0.5}}}}}},
            {"b", {{"plain", {{"psnr", {32, 32}}, {"mse", {0.3, 0.3}}, {"ssim", {0.5, 0.5}}}}}},
            {"c", {{"plain", {{"psnr", {32, 32}}, {"mse", {0.1, 0.1}}, {"ssim", {0.5, 0.5}}}}}}});
  const Comparison c = CompareReports(reports, {});
  EXPECT_EQ(c.metrics, (std::vector<std::string>{"psnr", "ssim", "mse"}));  // headline order
  EXPECT_EQ(Cell(c, "a", "psnr").rank, 3);                                  // higher is better
  EXPECT_EQ(Cell(c, "b", "psnr").rank, 1);
  EXPECT_EQ(Cell(c, "c", "psnr").rank, 1);
  EXPECT_EQ(Cell(c, "a", "mse").rank, 1);  // lower is better
  EXPECT_EQ(Cell(c, "b", "mse").rank, 3);
  EXPECT_EQ(Cell(c, "c", "mse").rank, 1);
  for (const char* name : {"a", "b", "c"}) EXPECT_EQ(Cell(c, name, "ssim").rank, 1);
}

TEST(Compare, RanksAreWithinARolloutAndSkipUndefinedMeans) {
  test::TempDir tmp;
  auto reports = Read(tmp, {{"a", {{"plain", {{"psnr", {20}}}}, {"retrace", {{"psnr", {40}}}}}},
                            {"b", {{"plain", {{"psnr", {25}}}}, {"retrace", {{"psnr", {NAN}}}}}}});
  const Comparison c = CompareReports(reports, {});
  ASSERT_EQ(c.rows.size(), 4u);
  EXPECT_EQ(c.rows[0].rollout, "plain");  // grouped by rollout, checkpoints in order
  EXPECT_EQ(c.rows[1].checkpoint, "b");
  EXPECT_EQ(Cell(c, "a", "psnr").rank, 2);
  EXPECT_EQ(Cell(c, "b", "psnr").rank, 1);
  EXPECT_EQ(Cell(c, "a", "psnr", "retrace").rank, 1);
  EXPECT_FALSE(Cell(c, "b", "psnr", "retrace").rank.has_value());
  EXPECT_TRUE(std::isnan(Cell(c, "b", "psnr", "retrace").mean));
}

TEST(Compare, DeltasArePairedDifferencesToTheBaseline) {
  test::TempDir tmp;
  auto reports = Read(
      tmp, {{"a", {{"plain", {{"psnr", {30, 31, 29, 30}}}}}, {{"plain", {{"fvd_style", 12.5}}}}},
            {"b", {{"plain", {{"psnr", {31, 33, 29, 32}}}}}, {{"plain", {{"fvd_style", 10.0}}}}}});
  const Comparison c = CompareReports(reports, {.baseline = "a", .resamples = 200});
  const MetricComparison& b = Cell(c, "b", "psnr");
  EXPECT_DOUBLE_EQ(b.delta, 1.25);  // mean of (1, 2, 0, 2)
  EXPECT_EQ(b.pairs, 4);
  EXPECT_LE(b.delta_ci_low, b.delta);
  EXPECT_GE(b.delta_ci_high, b.delta);
  EXPECT_GE(b.delta_ci_low, 0.0);  // no resample of non-negative differences goes below 0
  const MetricComparison& base = Cell(c, "a", "psnr");
  EXPECT_TRUE(Row(c, "a").baseline);
  EXPECT_TRUE(std::isnan(base.delta));
  EXPECT_FALSE(base.significant.has_value());
  // A whole-set metric: difference of the summary values, no paired interval, untested.
  const MetricComparison& fvd = Cell(c, "b", "fvd_style");
  EXPECT_DOUBLE_EQ(fvd.delta, -2.5);
  EXPECT_TRUE(std::isnan(fvd.delta_ci_low));
  EXPECT_FALSE(fvd.significant.has_value());
  EXPECT_EQ(fvd.rank, 1);
}

TEST(Compare, BaselineOptionPicksTheReferenceCheckpoint) {
  test::TempDir tmp;
  auto reports =
      Read(tmp, {{"a", {{"plain", {{"mse", {1, 1}}}}}}, {"b", {{"plain", {{"mse", {3, 5}}}}}}});
  const Comparison c = CompareReports(reports, {.baseline = "b"});
  EXPECT_EQ(c.baseline, "b");
  EXPECT_DOUBLE_EQ(Cell(c, "a", "mse").delta, -3.0);
  EXPECT_TRUE(std::isnan(Cell(c, "b", "mse").delta));
}

TEST(Compare, ClearlyBetterOnEveryEpisodeIsSignificant) {
  test::TempDir tmp;
  std::vector<double> base, better;
  for (int k = 0; k < 24; ++k) {
    base.push_back(20 + 0.37 * (k % 7));
    better.push_back(base.back() + 1.5 + 0.1 * (k % 3));
  }
  auto reports = Read(tmp, {{"base", {{"plain", {{"psnr", base}}}}},
                            {"better", {{"plain", {{"psnr", better}}}}},
                            {"same", {{"plain", {{"psnr", base}}}}}});
  const Comparison c = CompareReports(reports, {.seed = 3});
  const MetricComparison& b = Cell(c, "better", "psnr");
  EXPECT_GT(b.delta_ci_low, 1.4);
  EXPECT_EQ(b.significant, true);
  const MetricComparison& s = Cell(c, "same", "psnr");
  EXPECT_EQ(s.delta, 0.0);
  EXPECT_EQ(s.delta_ci_low, 0.0);
  EXPECT_EQ(s.delta_ci_high, 0.0);
  EXPECT_EQ(s.significant, false);
  EXPECT_EQ(s.rank, Cell(c, "base", "psnr").rank);  // a tie
}

TEST(Compare, NoisyDifferencesAroundZeroAreNotSignificant) {
  const std::vector<double> base = {1, 2, 3, 4, 5, 6, 7, 8};
  const std::vector<double> other = {2, 1, 4, 3, 6, 5, 8, 7};  // differences +1, -1, ...
  const PairedDelta d = PairedBootstrapDelta(other, base, 2000, 0, 0.95);
  EXPECT_EQ(d.delta, 0.0);
  EXPECT_LT(d.ci_low, 0.0);
  EXPECT_GT(d.ci_high, 0.0);
  // Below two pairs, or without resamples, there is no interval.
  EXPECT_TRUE(std::isnan(PairedBootstrapDelta({1}, {0}, 100, 0, 0.95).ci_low));
  EXPECT_TRUE(std::isnan(PairedBootstrapDelta(other, base, 0, 0, 0.95).ci_high));
}

TEST(Compare, PairsOnlyEpisodesBothReportsScored) {
  test::TempDir tmp;
  FakeReport a{"a", {{"plain", {{"ssim", {0.5, 0.5, 0.5, 0.5, NAN}}}}}};
  FakeReport b{"b", {{"plain", {{"ssim", {0.9, 0.9, 0.6, 0.6, 0.6}}}}}, {}, 2};  // episodes 2..6
  const Comparison c = CompareReports(Read(tmp, {a, b}), {});
  const MetricComparison& m = Cell(c, "b", "ssim");
  EXPECT_EQ(m.pairs, 2);  // episodes 2 and 3; episode 4 is undefined in a
  EXPECT_NEAR(m.delta, 0.4, 1e-12);
}

TEST(Compare, SameSeedSameBytesAndTheSeedOnlyMovesIntervals) {
  test::TempDir tmp;
  std::vector<double> a, b;
  for (int k = 0; k < 12; ++k) {
    a.push_back(20 + std::sin(k));
    b.push_back(a.back() + std::cos(3.1 * k));  // differences of both signs, all distinct
  }
  auto reports = Read(tmp, {{"a", {{"plain", {{"psnr", a}}}}}, {"b", {{"plain", {{"psnr", b}}}}}});
  const std::string first = ComparisonToCsv(CompareReports(reports, {.seed = 1}));
  EXPECT_EQ(first, ComparisonToCsv(CompareReports(reports, {.seed = 1})));
  const Comparison other = CompareReports(reports, {.seed = 2});
  const Comparison one = CompareReports(reports, {.seed = 1});
  EXPECT_EQ(Cell(other, "b", "psnr").delta, Cell(one, "b", "psnr").delta);
  EXPECT_NE(ComparisonToCsv(other), first);
}

TEST(Compare, EachRowAgainstItsOwnCopyLastIsPairedAndReadsInTheMetricsDirection) {
  test::TempDir tmp;
  FakeReport a{"a",
               {{"plain",
                 {{"psnr", {30, 32, 31}},
                  {"ssim", {0.5, 0.6, 0.7}},
                  {"mse", {1, 1.2, 1}},
                  {"lpips_style", {0.5, 0.75, 1}}}},
                {"copy_last",
                 {{"psnr", {28, 29, 30}},
                  {"ssim", {0.6, 0.5, 0.7}},
                  {"mse", {2, 2.1, 2}},
                  {"lpips_style", {0.25, 0.5, 0.75}}}}},
               {{"plain", {{"fvd_style", 10.0}}}, {"copy_last", {{"fvd_style", 12.5}}}}};
  // b's own copy_last is better than its plain rollout; a's copy_last must not be used for b.
  FakeReport b{"b", {{"plain", {{"psnr", {30, 32, 31}}}}, {"copy_last", {{"psnr", {31, 33, 32}}}}}};
  const Comparison c = CompareReports(Read(tmp, {a, b}), {.resamples = 500});
  EXPECT_TRUE(c.has_copy_last);
  const MetricComparison& psnr = Cell(c, "a", "psnr");
  EXPECT_DOUBLE_EQ(psnr.vs_copy_last, 2.0);  // mean of (2, 3, 1)
  EXPECT_GE(psnr.vs_copy_last_ci_low, 1.0);  // no resample goes below the smallest difference
  EXPECT_LE(psnr.vs_copy_last_ci_high, 3.0);
  EXPECT_EQ(psnr.beats_copy_last, 1);                 // higher PSNR: better than copying
  EXPECT_EQ(Cell(c, "a", "mse").beats_copy_last, 1);  // lower MSE on every episode: better
  EXPECT_NEAR(Cell(c, "a", "mse").vs_copy_last, -0.9666666666666667, 1e-12);
  EXPECT_EQ(Cell(c, "a", "lpips_style").beats_copy_last, -1);  // +0.25 everywhere: worse
  EXPECT_DOUBLE_EQ(Cell(c, "a", "lpips_style").vs_copy_last_ci_low, 0.25);
  EXPECT_EQ(Cell(c, "a", "ssim").beats_copy_last, 0);  // -0.1, +0.1, 0: indistinguishable
  // A whole-set metric: the difference only.
  EXPECT_DOUBLE_EQ(Cell(c, "a", "fvd_style").vs_copy_last, -2.5);
  EXPECT_FALSE(Cell(c, "a", "fvd_style").beats_copy_last.has_value());
  // Against its own copy_last, also in the baseline report's rows; none in copy_last's rows.
  EXPECT_DOUBLE_EQ(Cell(c, "b", "psnr").vs_copy_last, -1.0);
  EXPECT_EQ(Cell(c, "b", "psnr").beats_copy_last, -1);
  EXPECT_TRUE(std::isnan(Cell(c, "a", "psnr", "copy_last").vs_copy_last));
  EXPECT_FALSE(Cell(c, "a", "psnr", "copy_last").beats_copy_last.has_value());
}

TEST(CompareFormat, CopyLastColumnsAndTableAppearWithACopyLastRollout) {
  test::TempDir tmp;
  auto reports =
      Read(tmp, {{"a",
                  {{"plain", {{"mse", {1, 2, 3}}, {"lpips_style", {0.5, 0.5, 0.5}}}},
                   {"copy_last", {{"mse", {2, 3, 4}}, {"lpips_style", {0.25, 0.25, 0.25}}}}}}});
  EXPECT_EQ(ComparisonToCsv(CompareReports(reports, {.metrics = {"mse"}, .resamples = 0})),
            "checkpoint,rollout,mse,mse_ci_low,mse_ci_high,mse_delta,mse_delta_ci_low,"
            "mse_delta_ci_high,mse_delta_significant,mse_rank,mse_vs_copy_last,"
            "mse_vs_copy_last_ci_low,mse_vs_copy_last_ci_high,mse_beats_copy_last\n"
            "a,plain,2,1,3,,,,,1,-1,,,\n"
            "a,copy_last,3,2,4,,,,,1,,,,\n");
  const std::string md = ComparisonToMarkdown(CompareReports(reports, {}), 0.95);
  EXPECT_THAT(md, HasSubstr("| checkpoint | rollout | Δ mse ↓ | Δ lpips_style ↓ |\n"));
  EXPECT_THAT(md, HasSubstr("| a | plain | -1 [-1, -1] better | +0.25 [+0.25, +0.25] worse |"));
  EXPECT_THAT(md, Not(HasSubstr("| a | copy_last | -")));  // no row against itself
}

TEST(CompareFormat, CsvHasTheDocumentedColumnsAndEmptyCellsForUndefined) {
  test::TempDir tmp;
  auto reports = Read(
      tmp, {{"a", {{"plain", {{"psnr", {30, 32}}}}}}, {"b", {{"plain", {{"psnr", {31, 34}}}}}}});
  const std::string csv = ComparisonToCsv(CompareReports(reports, {.resamples = 0}));
  EXPECT_EQ(csv,
            "checkpoint,rollout,psnr,psnr_ci_low,psnr_ci_high,psnr_delta,psnr_delta_ci_low,"
            "psnr_delta_ci_high,psnr_delta_significant,psnr_rank\n"
            "a,plain,31,30,32,,,,,2\n"
            "b,plain,32.5,31.5,33.5,1.5,,,,1\n");
  EXPECT_EQ(FormatNumber(1.0 / 3), "0.333333333");
  EXPECT_EQ(FormatNumber(INFINITY), "");
}

TEST(CompareFormat, MarkdownIsOneTableWithDirectionsAndStars) {
  test::TempDir tmp;
  auto reports = Read(
      tmp, {{"a", {{"plain", {{"mse", {1, 1, 1}}}}}}, {"b", {{"plain", {{"mse", {2, 2, 2}}}}}}});
  const std::string md = ComparisonToMarkdown(CompareReports(reports, {}), 0.95);
  EXPECT_THAT(md, HasSubstr("| checkpoint | rollout | mse ↓ | Δ mse |"));
  EXPECT_THAT(md, HasSubstr("| a | plain | **1 [0, 2] #1** | baseline |"));
  EXPECT_THAT(md, HasSubstr("| b | plain | 2 [1, 3] #2 | +1 [+1, +1] * |"));
}

TEST(MetricDirection, UncertaintySignalsTrackingTheErrorAreBetterHigher) {
  for (const char* metric : {"token_entropy_auroc", "retrace_disagreement_error_pearson",
                             "sample_disagreement_error_spearman", "uncertainty_error_corr"}) {
    EXPECT_EQ(MetricDirection(metric), Direction::kHigherIsBetter) << metric;
  }
  // The signals themselves and bare suffixes have no better direction.
  for (const char* metric : {"token_entropy", "retrace_disagreement", "_auroc", "uncertainty"}) {
    EXPECT_EQ(MetricDirection(metric), std::nullopt) << metric;
  }
  EXPECT_EQ(MetricDirection("mse_block"), Direction::kLowerIsBetter);
}

}  // namespace
}  // namespace wm::report

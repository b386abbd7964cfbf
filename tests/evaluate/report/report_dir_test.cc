// Reading report directories and refusing bad ones: every error names the file, and for a bad row
// its line and column.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>

#include "evaluate/report/compare.h"
#include "evaluate/report/plot_launcher.h"
#include "report_fixture.h"
#include "tests/core/test_util.h"

namespace wm::report {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

class ReportDir : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::WriteFakeReport(
        tmp_.path().string(),
        {"ckpt",
         {{"plain", {{"psnr", {30, 31}}, {"ssim", {0.5, NAN}}}}, {"retrace", {{"psnr", {29, 30}}}}},
         {{"plain", {{"fvd_style", 3.5}}}}});
  }
  std::string File(const std::string& name) const { return dir_ + "/" + name; }
  std::string ReadError() const {
    return test::ErrorText([&] { ReadCheckpointReport(dir_); });
  }
  // Replaces the first occurrence of `from` in `name`.
  void Edit(const std::string& name, const std::string& from, const std::string& to) {
    std::string text = test::ReadText(File(name));
    const size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    test::WriteText(File(name), text.replace(at, from.size(), to));
  }

  test::TempDir tmp_;
  std::string dir_;
};

TEST_F(ReportDir, ReadsEveryRowWithUndefinedCellsAsNaN) {
  const CheckpointReport r = ReadCheckpointReport(dir_);
  EXPECT_EQ(r.name, "ckpt");
  EXPECT_EQ(r.summary.size(), 4u);
  EXPECT_DOUBLE_EQ(r.summary.at({"plain", "psnr"}).mean, 30.5);
  EXPECT_EQ(r.summary.at({"plain", "ssim"}).n, 1);
  EXPECT_TRUE(std::isnan(r.summary.at({"plain", "fvd_style"}).ci_low));
  const auto& ssim = r.per_episode.at({"plain", "ssim"});
  EXPECT_TRUE(std::isnan(ssim.at(1).value));
  EXPECT_EQ(ssim.at(1).policy_id, "noisy");
  EXPECT_EQ(ssim.at(1).line, 5);
  EXPECT_TRUE(r.HasRollout("retrace"));
  EXPECT_FALSE(r.HasRollout("copy_last"));
}

TEST_F(ReportDir, MissingFilesAreNamed) {
  std::filesystem::remove(File("per_episode.csv"));
  EXPECT_THAT(ReadError(), AllOf(HasSubstr(File("per_episode.csv")), HasSubstr("missing file")));
  std::filesystem::remove(File("manifest.json"));
  EXPECT_THAT(ReadError(), AllOf(HasSubstr(File("manifest.json")), HasSubstr("missing file")));
  EXPECT_THAT(test::ErrorText([&] { ReadCheckpointReport(tmp_ / "nowhere"); }),
              HasSubstr("not a directory"));
}

TEST_F(ReportDir, MissingColumnNamesTheFileLineAndColumn) {
  Edit("per_episode.csv", "metric,value", "metric,score");
  EXPECT_THAT(ReadError(), AllOf(HasSubstr(File("per_episode.csv") + ": line 1"),
                                 HasSubstr("missing column 'value'")));
}

TEST_F(ReportDir, BadCellsNameTheFileLineAndColumn) {
  Edit("summary.csv", "30.5", "abc");
  EXPECT_THAT(ReadError(), AllOf(HasSubstr(File("summary.csv") + ": line 2"),
                                 HasSubstr("column 'mean': 'abc' is not a number")));
  Edit("summary.csv", "abc", "inf");
  EXPECT_THAT(ReadError(), HasSubstr("column 'mean': 'inf' is not finite"));
  Edit("summary.csv", "inf", "30.5");
  Edit("summary.csv", ",2\n", ",-2\n");
  EXPECT_THAT(ReadError(), HasSubstr("column 'n': '-2' is not a count"));
  Edit("summary.csv", ",-2\n", ",2\n");
  Edit("per_episode.csv", "ckpt,plain,1,", "ckpt,plain,x,");
  EXPECT_THAT(ReadError(), AllOf(HasSubstr(File("per_episode.csv") + ": line 3"),
                                 HasSubstr("column 'episode': 'x' is not an episode index")));
}

TEST_F(ReportDir, RowsOfAnotherCheckpointOrRepeatedAreRefused) {
  Edit("summary.csv", "ckpt,retrace", "other,retrace");
  EXPECT_THAT(ReadError(), AllOf(HasSubstr(File("summary.csv") + ": line 4"),
                                 HasSubstr("column 'checkpoint': 'other'")));
  Edit("summary.csv", "other,retrace", "ckpt,retrace");
  Edit("per_episode.csv", "ckpt,plain,1,noisy,psnr", "ckpt,plain,0,expert,psnr");
  EXPECT_THAT(ReadError(), AllOf(HasSubstr(File("per_episode.csv") + ": line 3"),
                                 HasSubstr("episode 0 is listed twice")));
}

TEST_F(ReportDir, ManifestNeedsItsKeys) {
  test::WriteText(File("manifest.json"), R"({"checkpoint": {"name": "ckpt"}, "seed": 0})");
  EXPECT_THAT(ReadError(),
              AllOf(HasSubstr(File("manifest.json")), HasSubstr("key 'checkpoint.sha256'")));
  test::WriteText(File("manifest.json"), "[1, 2]");
  EXPECT_THAT(ReadError(), HasSubstr("expected a JSON object"));
  test::WriteText(File("manifest.json"), "{");
  EXPECT_THAT(ReadError(), HasSubstr("not valid JSON"));
}

TEST_F(ReportDir, CompareRefusesUnknownMetricsRolloutsAndBaselines) {
  const std::vector<CheckpointReport> reports = {ReadCheckpointReport(dir_)};
  auto error = [&](const CompareOptions& o) {
    return test::ErrorText([&] { CompareReports(reports, o); });
  };
  EXPECT_THAT(error({.metrics = {"psnr", "sharpness"}}),
              AllOf(HasSubstr("--metrics"), HasSubstr("unknown metric 'sharpness'")));
  EXPECT_THAT(error({.metrics = {"mse_arm"}}),
              AllOf(HasSubstr(File("summary.csv")), HasSubstr("metric 'mse_arm' is in no")));
  EXPECT_THAT(error({.rollout = "copy_last"}),
              AllOf(HasSubstr(File("summary.csv")), HasSubstr("they have: plain, retrace")));
  EXPECT_THAT(error({.baseline = "nope"}), HasSubstr("'nope' is none of the compared"));
  EXPECT_THAT(test::ErrorText([&] {
                CompareReports({reports[0], reports[0]}, {});
              }),
              HasSubstr("checkpoint name 'ckpt' is also the name of"));
}

TEST_F(ReportDir, EpisodesOfDifferentPoliciesCannotBePaired) {
  const std::string other =
      test::WriteFakeReport(tmp_ / "b", {"other", {{"plain", {{"psnr", {1, 2}}}}}});
  const std::string file = other + "/per_episode.csv";
  std::string text = test::ReadText(file);
  test::WriteText(file, text.replace(text.find("1,noisy"), 7, "1,expert"));
  const std::string error = test::ErrorText([&] {
    CompareReports({ReadCheckpointReport(dir_), ReadCheckpointReport(other)}, {});
  });
  EXPECT_THAT(error, AllOf(HasSubstr(file + ": line 3"),
                           HasSubstr("episode 1 is 'expert' here but 'noisy'"),
                           HasSubstr("different data")));
}

TEST(PlotLauncher, CommandLineRunsTheScriptOnTheReports) {
  const PlotOptions o{.report_dirs = {"r/a", "r/b"},
                      .out_dir = "plots",
                      .metrics = {"psnr"},
                      .script = "/x/plot_report.py",
                      .wm_metrics = "/bin/wm-metrics"};
  const std::vector<std::string> args = PlotCommandLine(o);
  EXPECT_EQ(args[0], "/usr/bin/python3");
  EXPECT_EQ(args[1], "/x/plot_report.py");
  ASSERT_GE(args.size(), 3u);
  EXPECT_EQ(std::vector<std::string>(args.end() - 3, args.end()),
            (std::vector<std::string>{"--", "r/a", "r/b"}));
  EXPECT_THAT(FindPlotScript(), HasSubstr("plot_report.py"));
}

}  // namespace
}  // namespace wm::report

#include "evaluate/report/compare_command.h"

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <memory>

#include "core/atomic_file.h"
#include "core/log.h"
#include "evaluate/report/compare.h"
#include "evaluate/report/compare_format.h"
#include "evaluate/report/metric_direction.h"

namespace wm::report {
namespace {

constexpr const char* kFooter = R"(
Input: report directories REPORT_DIR/<checkpoint> written by wm-eval (manifest.json, summary.csv,
per_episode.csv; docs/reports.md).

Output: one row per checkpoint x rollout (rows grouped by rollout), columns checkpoint, rollout,
then per metric m:
  m, m_ci_low, m_ci_high      mean and bootstrap interval, copied from summary.csv
  m_delta                     m minus the baseline's m, same rollout: the mean of the paired
                              per-episode differences (episodes both reports scored), or the
                              difference of the summary means for whole-set metrics
                              (fvd_style, correlations, value_gap, ranking_accuracy)
  m_delta_ci_low, _ci_high    95% paired bootstrap interval (episodes resampled, --resamples,
                              --seed); empty for whole-set metrics and below 2 paired episodes
  m_delta_significant         1 when that interval excludes 0, else 0; empty when untested
  m_rank                      1 = best among the checkpoints of the rollout; ties share the
                              better rank (1, 2, 2, 4); direction per metric (higher is better
                              for psnr, ssim, correlations, ranking_accuracy, delta_tpsnr;
                              lower for mse*, lpips_style, fvd_style, value_gap, return_error,
                              moved_error_ratio)
  m_vs_copy_last, _ci_low,    "does it beat copying?": m minus the same report's copy_last
    _ci_high                  rollout, paired over episodes, with its paired bootstrap interval
                              (only when some report has a copy_last rollout)
  m_beats_copy_last           1 better than copy_last (the interval excludes 0 on the metric's
                              better side), -1 worse, 0 the interval contains 0; empty untested
The baseline row's delta cells are empty; copy_last rows have no vs_copy_last cells. Numbers are printed with %.9g, undefined ones as empty
cells: the same inputs and --seed give the same bytes. Schema: schemas/report-compare.schema.json.

Examples:
  wm-report compare reports/dyn-small reports/dyn-base reports/dyn-large --out compare.csv
  wm-report compare reports/* --baseline dyn-base --metrics psnr,ssim,value_gap \
      --rollout plain --markdown compare.md

Exit codes: 0 success, 1 bad input (the message names the file, line and column), 2 usage.)";

struct CompareCommandOptions {
  std::vector<std::string> dirs;
  std::string out, markdown;
  CompareOptions compare;
};

void Run(const CompareCommandOptions& o) {
  std::vector<CheckpointReport> reports;
  for (const auto& dir : o.dirs) reports.push_back(ReadCheckpointReport(dir));
  const Comparison comparison = CompareReports(reports, o.compare);
  WriteFileAtomically(o.out, ComparisonToCsv(comparison));
  if (!o.markdown.empty()) {
    WriteFileAtomically(o.markdown, ComparisonToMarkdown(comparison, o.compare.level));
  }
  spdlog::info("compared {} checkpoints on {} metrics ({} rows, baseline {}) -> {}", reports.size(),
               comparison.metrics.size(), comparison.rows.size(), comparison.baseline, o.out);
}

}  // namespace

void AddCompareCommand(CLI::App& app) {
  auto o = std::make_shared<CompareCommandOptions>();
  CLI::App* cmd =
      app.add_subcommand("compare",
                         "Checkpoints side by side: metrics, deltas to a baseline with paired "
                         "bootstrap intervals, ranks");
  cmd->footer(kFooter);
  cmd->add_option("reports", o->dirs, "Report directories REPORT_DIR/<checkpoint>")->required();
  cmd->add_option("--out", o->out, "compare.csv to write")->required();
  cmd->add_option("--baseline", o->compare.baseline,
                  "Checkpoint name the deltas are against (default: the first report)");
  cmd->add_option("--metrics", o->compare.metrics,
                  "Comma-separated metrics (default: the headline metrics the reports have; "
                  "known: " +
                      KnownMetricsText() + ")")
      ->delimiter(',')
      ->allow_extra_args(false);
  cmd->add_option("--rollout", o->compare.rollout,
                  "plain, retrace, copy_last, copy_last_tokens, tokenizer_recon or all")
      ->capture_default_str();
  cmd->add_option("--markdown", o->markdown,
                  "Also write the table (and one against copy_last) as Markdown to this file");
  cmd->add_option("--seed", o->compare.seed, "Paired bootstrap seed")->capture_default_str();
  cmd->add_option("--resamples", o->compare.resamples,
                  "Paired bootstrap replicates (0: no delta intervals)")
      ->check(CLI::Range(0, 10'000'000))
      ->capture_default_str();
  cmd->callback([o] { Run(*o); });
}

}  // namespace wm::report

#include "evaluate/report/plot_command.h"

#include <CLI/CLI.hpp>
#include <memory>

#include "evaluate/report/plot_launcher.h"

namespace wm::report {
namespace {

constexpr const char* kFooter = R"(
Draws with matplotlib (Agg) through scripts/plot_report.py, which it runs with --python:
  step_<metric>.png     mean and 95% band vs horizon step, one line per checkpoint x rollout
                        (per_step.csv); identical baseline curves (copy_last,
                        copy_last_tokens, tokenizer_recon) are drawn once
  values.png            real vs model value per policy, a panel per rollout, y = x for
                        reference (values.csv)
  scaling_<metric>_<rollout>.png, scaling_points.csv, scaling_fit.json
                        when at least two manifests carry "scale" (parameters or compute):
                        --scaling-metric (summary.csv mean) vs scale on log axes with the
                        power law y = a x^-b + c fitted by `wm-metrics scaling` (drawn when the
                        fit succeeds: at least 3 distinct scales)
The script is found as $WMKIT_SCRIPTS/plot_report.py, else scripts/plot_report.py above this
executable, else in the source tree it was built from (--script overrides); wm-metrics is looked
for beside this executable (--wm-metrics overrides).

Examples:
  wm-report plot reports/dyn-small reports/dyn-base reports/dyn-large --out plots/
  wm-report plot reports/* --out plots/ --metrics psnr,ssim --scaling-metric lpips_style

Exit codes: 0 success, 1 bad input (the message names the file), 2 usage.)";

}  // namespace

void AddPlotCommand(CLI::App& app) {
  auto o = std::make_shared<PlotOptions>();
  CLI::App* cmd = app.add_subcommand(
      "plot", "PNG plots: metric vs horizon step, real vs model value, metric vs scale");
  cmd->footer(kFooter);
  cmd->add_option("reports", o->report_dirs, "Report directories REPORT_DIR/<checkpoint>")
      ->required();
  cmd->add_option("--out", o->out_dir, "Directory for the PNGs")->required();
  cmd->add_option("--metrics", o->metrics, "Comma-separated per-step metrics (default: all)")
      ->delimiter(',')
      ->allow_extra_args(false);
  cmd->add_option("--rollout", o->rollout, "Rollout to draw (plain, retrace, ...) or all")
      ->capture_default_str();
  cmd->add_option("--scaling-metric", o->scaling_metric, "Metric plotted against scale")
      ->capture_default_str();
  cmd->add_option("--scaling-rollout", o->scaling_rollout, "Rollout of the scaling plot")
      ->capture_default_str();
  cmd->add_option("--script", o->script, "plot_report.py to run");
  cmd->add_option("--wm-metrics", o->wm_metrics, "wm-metrics executable for the scaling fit");
  cmd->add_option("--python", o->python, "Python interpreter")->capture_default_str();
  cmd->callback([o] { ExecPlotScript(*o); });
}

}  // namespace wm::report

#include "metrics/tools/scaling_command.h"

#include <CLI/CLI.hpp>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>

#include "metrics/scaling/scaling_io.h"

namespace wm::metrics {
namespace {

constexpr const char* kFooter = R"(
Input: a CSV with a header row and the columns x (compute, parameters or data; > 0) and y (the
loss or metric at x), optionally label; any column order.

Forms:
  power      y = a x^-b + c, least squares with Ceres, bounds b >= --b-min, c >= --c-min
  loglinear  log y = log a - b log x, least squares on log-log axes (needs y > 0)
--robust huber|cauchy down-weights outlying points (scale --robust-scale, 0: from the MAD of the
least-squares residuals). Standard errors: sqrt of the diagonal of sigma^2 (J^T J)^-1 at the
solution, sigma^2 = RSS / (n - p); null when n = p. --extrapolate predicts y (with a delta-method
standard error) at further x values.

Output: JSON (schemas/scaling-fit.schema.json) or CSV quantity,label,x,value,std_error.

Examples:
  wm-metrics scaling --points losses.csv
  wm-metrics scaling --points losses.csv --robust huber --extrapolate 1e21,1e22 --format csv
  wm-metrics scaling --points losses.csv --form loglinear

Definitions: docs/metrics-value.md ("Scaling-law fit").
Exit codes: 0 success, 1 bad input (the message names the file, line and column), other
non-zero: usage error.)";

struct ScalingCommandOptions {
  std::string points;
  ScalingFitOptions fit;
  double b_min = 0, c_min = 0;
  bool unbounded = false;
  std::vector<double> extrapolate;
  std::string format = "json";
};

void Run(ScalingCommandOptions& o) {
  o.fit.b_min = o.unbounded ? std::nullopt : std::optional<double>(o.b_min);
  o.fit.c_min = o.unbounded ? std::nullopt : std::optional<double>(o.c_min);
  const ScalingReport report = FitScalingLawFromCsv(o.points, o.fit, o.extrapolate);
  std::cout << (o.format == "json" ? ScalingReportToJson(report).dump(2) + "\n"
                                   : ScalingReportToCsv(report));
}

}  // namespace

void AddScalingCommand(CLI::App& app) {
  auto o = std::make_shared<ScalingCommandOptions>();
  const std::map<std::string, ScalingForm> forms = {{"power", ScalingForm::kPower},
                                                    {"loglinear", ScalingForm::kLogLinear}};
  const std::map<std::string, RobustLoss> losses = {
      {"none", RobustLoss::kNone}, {"huber", RobustLoss::kHuber}, {"cauchy", RobustLoss::kCauchy}};
  CLI::App* cmd = app.add_subcommand(
      "scaling", "Fit a scaling law y = a x^-b + c (or log-linear) with standard errors");
  cmd->footer(kFooter);
  cmd->add_option("--points", o->points, "Points CSV: x, y[, label]")->required();
  cmd->add_option("--form", o->fit.form, "power or loglinear")
      ->transform(CLI::CheckedTransformer(forms))
      ->option_text("power|loglinear (default power)");
  cmd->add_option("--robust", o->fit.robust, "Robust loss: none, huber, cauchy")
      ->transform(CLI::CheckedTransformer(losses))
      ->option_text("none|huber|cauchy (default none)");
  cmd->add_option("--robust-scale", o->fit.robust_scale,
                  "Robust loss scale in residual units (0: automatic)")
      ->check(CLI::Range(0.0, std::numeric_limits<double>::max()))
      ->capture_default_str();
  CLI::Option* b_min =
      cmd->add_option("--b-min", o->b_min, "Lower bound of the exponent b (power form)")
          ->capture_default_str();
  CLI::Option* c_min =
      cmd->add_option("--c-min", o->c_min, "Lower bound of the offset c")->capture_default_str();
  cmd->add_flag("--unbounded", o->unbounded, "No bounds on b and c")
      ->excludes(b_min)
      ->excludes(c_min);
  cmd->add_option("--max-iterations", o->fit.max_iterations, "Solver iterations")
      ->check(CLI::Range(1, 1'000'000))
      ->capture_default_str();
  cmd->add_option("--extrapolate", o->extrapolate, "Comma-separated x values to predict at")
      ->delimiter(',');
  cmd->add_option("--format", o->format, "json or csv")
      ->check(CLI::IsMember({"json", "csv"}))
      ->capture_default_str();
  cmd->callback([o] { Run(*o); });
}

}  // namespace wm::metrics

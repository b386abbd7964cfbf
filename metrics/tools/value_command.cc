#include "metrics/tools/value_command.h"

#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "metrics/value/value_io.h"

namespace wm::metrics {
namespace {

constexpr const char* kFooter = R"(
Input: a CSV with a header row and the columns episode, policy_id, real_return, model_return
(any order, other columns ignored), one row per episode: its return in the real environment and
the return of the same episode rolled out in the world model.

Output (JSON, schemas/value-metrics.schema.json; or CSV metric,policy_id,value,ci_low,ci_high,
resamples_defined), each metric with a percentile bootstrap interval:
  value_gap             mean over policies of |V_real - V_model|, V = mean return of a policy
  normalized_value_gap  value_gap / (max - min of V_real); null when all V_real are equal
  optimism              mean over policies of V_model - V_real (> 0: the model is optimistic)
  policy_ranking        pearson, spearman, kendall_tau_b, top1_agreement, pairwise_accuracy
                        between V_real and V_model across policies (null below 2 policies)
  episode_correlation   pearson, spearman, kendall_tau_b of the returns across episodes
  per_policy            real_value, model_value, value_gap, optimism of each policy
Undefined values (a correlation of constant values, ...) are null. The bootstrap resamples
episodes with replacement within each policy; the same --seed gives the same intervals.

Examples:
  wm-metrics value --returns returns.csv
  wm-metrics value --returns returns.csv --bootstrap 5000 --seed 7 --ci 0.9 --format csv

Definitions: docs/metrics-value.md.
Exit codes: 0 success, 1 bad input (the message names the file, line and column), other
non-zero: usage error.)";

struct ValueCommandOptions {
  std::string returns;
  BootstrapOptions bootstrap;
  std::string format = "json";
};

// CLI::Range includes its ends; a 0% or 100% interval is meaningless.
CLI::Validator OpenUnitInterval() {
  return CLI::Validator(
      [](std::string& text) {
        double v = 0;
        const bool ok = CLI::detail::lexical_cast(text, v) && v > 0 && v < 1;
        return ok ? std::string() : "must be in (0, 1), got " + text;
      },
      "in (0, 1)");
}

void Run(const ValueCommandOptions& o) {
  const ValueMetrics metrics = ComputeValueMetricsFromCsv(o.returns, o.bootstrap);
  std::cout << (o.format == "json" ? ValueMetricsToJson(metrics).dump(2) + "\n"
                                   : ValueMetricsToCsv(metrics));
}

}  // namespace

void AddValueCommand(CLI::App& app) {
  auto o = std::make_shared<ValueCommandOptions>();
  CLI::App* cmd = app.add_subcommand(
      "value", "Value gap, optimism and policy ranking from real vs world-model returns");
  cmd->footer(kFooter);
  cmd->add_option("--returns", o->returns, "Per-episode returns CSV")->required();
  cmd->add_option("--bootstrap", o->bootstrap.resamples, "Bootstrap resamples (0: no intervals)")
      ->check(CLI::Range(0, 100'000'000))
      ->capture_default_str();
  cmd->add_option("--seed", o->bootstrap.seed, "Bootstrap seed")->capture_default_str();
  cmd->add_option("--ci", o->bootstrap.level, "Confidence level of the intervals, in (0, 1)")
      ->check(OpenUnitInterval())
      ->capture_default_str();
  cmd->add_option("--format", o->format, "json or csv")
      ->check(CLI::IsMember({"json", "csv"}))
      ->capture_default_str();
  cmd->callback([o] { Run(*o); });
}

}  // namespace wm::metrics

#include "evaluate/wpe_report.h"

#include <cmath>
#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"
#include "evaluate/aggregate.h"
#include "metrics/value/correlation.h"
#include "metrics/value/value_metrics.h"

namespace wm::evaluate {
namespace {

using nlohmann::json;

double MeanOrNan(const std::vector<double>& v) {
  if (v.empty()) return NAN;
  double s = 0;
  for (double x : v) s += x;
  return s / static_cast<double>(v.size());
}

json NumberOrNull(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

}  // namespace

std::vector<PolicyEstimate> ReadTrueValues(const std::string& path) {
  std::vector<PolicyEstimate> out;
  try {
    const json j = json::parse(ReadFile(path));
    Check(j.value("format", "") == "wmkit-policy-values",
          "not wm-sim-policy's policy_values.json (format is not wmkit-policy-values)",
          {.file = path, .key = "format"});
    for (const json& p : j.at("policies")) {
      out.push_back({p.at("policy").get<std::string>(), p.at("in_distribution").get<bool>(),
                     p.at("episodes").get<int64_t>(), p.at("true_value").get<double>(),
                     p.at("ci_low").get<double>(), p.at("ci_high").get<double>()});
    }
  } catch (const json::exception& e) {
    throw Error(std::string("cannot read the true values: ") + e.what(), {.file = path});
  }
  return out;
}

std::vector<WpeRow> PairWithTruth(const std::vector<PolicyEstimate>& model,
                                  const std::vector<PolicyEstimate>& truth,
                                  const std::string& truth_file) {
  std::vector<WpeRow> rows;
  for (const PolicyEstimate& m : model) {
    const PolicyEstimate* t = nullptr;
    for (const PolicyEstimate& c : truth) t = c.policy == m.policy ? &c : t;
    Check(t != nullptr, "has no true value for policy '" + m.policy + "'",
          {.file = truth_file, .key = "policies"});
    rows.push_back({*t, m, m.value - t->value});
  }
  return rows;
}

WpeSummary SummarizeWpe(const std::vector<WpeRow>& rows) {
  WpeSummary s{.num_policies = static_cast<int64_t>(rows.size())};
  std::vector<double> truth, model, gaps, abs_gaps, in_gaps, out_gaps;
  for (const WpeRow& r : rows) {
    truth.push_back(r.truth.value);
    model.push_back(r.model.value);
    gaps.push_back(r.gap);
    abs_gaps.push_back(std::abs(r.gap));
    (r.model.in_distribution ? in_gaps : out_gaps).push_back(r.gap);
  }
  s.spearman = metrics::Spearman(truth, model);
  s.kendall = metrics::KendallTauB(truth, model);
  s.pairwise_accuracy = metrics::PairwiseAccuracy(truth, model);
  s.mean_abs_gap = MeanOrNan(abs_gaps);
  s.optimism = MeanOrNan(gaps);
  s.optimism_in_distribution = MeanOrNan(in_gaps);
  s.optimism_out_of_distribution = MeanOrNan(out_gaps);
  s.num_in_distribution = static_cast<int64_t>(in_gaps.size());
  return s;
}

void WriteWpeReport(const std::string& dir, const std::vector<WpeRow>& rows, const WpeSummary& s,
                    const json& provenance) {
  std::string csv =
      "policy,in_distribution,true_value,true_ci_low,true_ci_high,true_episodes,wm_value,"
      "wm_ci_low,wm_ci_high,wm_episodes,gap,abs_gap\n";
  json policies = json::array();
  for (const WpeRow& r : rows) {
    csv += r.model.policy + "," + (r.model.in_distribution ? "true" : "false") + "," +
           Cell(r.truth.value) + "," + Cell(r.truth.ci_low) + "," + Cell(r.truth.ci_high) + "," +
           std::to_string(r.truth.episodes) + "," + Cell(r.model.value) + "," +
           Cell(r.model.ci_low) + "," + Cell(r.model.ci_high) + "," +
           std::to_string(r.model.episodes) + "," + Cell(r.gap) + "," + Cell(std::abs(r.gap)) +
           "\n";
    policies.push_back(r.model.policy);
  }
  const json summary = {
      {"format", "wmkit-wpe-summary"},
      {"format_version", 1},
      {"num_policies", s.num_policies},
      {"policies", policies},
      {"spearman", NumberOrNull(s.spearman)},
      {"kendall", NumberOrNull(s.kendall)},
      {"pairwise_accuracy", NumberOrNull(s.pairwise_accuracy)},
      {"mean_abs_gap", NumberOrNull(s.mean_abs_gap)},
      {"optimism", NumberOrNull(s.optimism)},
      {"optimism_in_distribution", NumberOrNull(s.optimism_in_distribution)},
      {"optimism_out_of_distribution", NumberOrNull(s.optimism_out_of_distribution)},
      {"num_in_distribution", s.num_in_distribution},
      {"gap", "wm_value - true_value (success rates)"},
      {"provenance", provenance}};
  const std::filesystem::path out(dir);
  WriteFileAtomically((out / "wpe.csv").string(), csv);
  WriteFileAtomically((out / "wpe_summary.json").string(), summary.dump(2) + "\n");
}

}  // namespace wm::evaluate

#include "metrics/value/value_io.h"

#include <cmath>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "metrics/value/csv_table.h"

namespace wm::metrics {
namespace {
using nlohmann::json;

// A metric's place in the output: top level (section ""), a section ("policy_ranking"), or one
// policy's entry (policy non-null).
struct NamedEstimate {
  std::string section, name;
  const PolicyValue* policy;
  const Estimate* estimate;
};

std::vector<NamedEstimate> Named(const ValueMetrics& m) {
  std::vector<NamedEstimate> out = {
      {"", "value_gap", nullptr, &m.value_gap},
      {"", "normalized_value_gap", nullptr, &m.normalized_value_gap},
      {"", "optimism", nullptr, &m.optimism},
      {"policy_ranking", "top1_agreement", nullptr, &m.top1_agreement},
      {"policy_ranking", "pairwise_accuracy", nullptr, &m.pairwise_accuracy}};
  for (const auto& [section, c] : {std::pair{"policy_ranking", &m.policy_correlation},
                                   std::pair{"episode_correlation", &m.episode_correlation}}) {
    out.insert(out.end(), {{section, "pearson", nullptr, &c->pearson},
                           {section, "spearman", nullptr, &c->spearman},
                           {section, "kendall_tau_b", nullptr, &c->kendall_tau_b}});
  }
  for (const PolicyValue& p : m.policies) {
    out.insert(out.end(), {{"", "real_value", &p, &p.real_value},
                           {"", "model_value", &p, &p.model_value},
                           {"", "value_gap", &p, &p.value_gap},
                           {"", "optimism", &p, &p.optimism}});
  }
  return out;
}

// JSON has no NaN: an undefined value is null.
json Number(double value) { return std::isfinite(value) ? json(value) : json(nullptr); }

json ToJson(const Estimate& e) {
  return {{"value", Number(e.value)},
          {"ci_low", Number(e.ci_low)},
          {"ci_high", Number(e.ci_high)},
          {"resamples_defined", e.resamples_defined}};
}

std::vector<EpisodeReturn> ReadReturns(const CsvTable& table) {
  const size_t episode = table.Column("episode"), policy = table.Column("policy_id");
  const size_t real = table.Column("real_return"), model = table.Column("model_return");
  Check(table.rows() > 0, "no episode rows after the header", {.file = table.path()});
  std::vector<EpisodeReturn> rows;
  for (size_t r = 0; r < table.rows(); ++r) {
    rows.push_back({table.NonEmpty(r, episode), table.NonEmpty(r, policy), table.Number(r, real),
                    table.Number(r, model)});
  }
  return rows;
}

}  // namespace

ValueMetrics ComputeValueMetricsFromCsv(const std::string& path, const BootstrapOptions& options) {
  options.Check();
  const CsvTable table = CsvTable::Read(path);
  const std::vector<EpisodeReturn> rows = ReadReturns(table);
  try {
    return ComputeValueMetrics(rows, options);
  } catch (const Error& e) {
    throw table.AtLine(e);
  }
}

json ValueMetricsToJson(const ValueMetrics& m) {
  json out = {{"episodes", m.episodes},
              {"policies", m.policies.size()},
              {"bootstrap",
               {{"resamples", m.bootstrap.resamples},
                {"seed", m.bootstrap.seed},
                {"level", m.bootstrap.level},
                {"scheme", "stratified: episodes resampled with replacement within each policy"}}},
              {"per_policy", json::array()}};
  for (const PolicyValue& p : m.policies) {
    out["per_policy"].push_back({{"policy_id", p.policy_id}, {"episodes", p.episodes}});
  }
  for (const NamedEstimate& n : Named(m)) {
    if (n.policy) {
      out["per_policy"][n.policy - m.policies.data()][n.name] = ToJson(*n.estimate);
    } else {
      (n.section.empty() ? out : out[n.section])[n.name] = ToJson(*n.estimate);
    }
  }
  return out;
}

std::string ValueMetricsToCsv(const ValueMetrics& m) {
  std::string out = "metric,policy_id,value,ci_low,ci_high,resamples_defined\n";
  for (const NamedEstimate& n : Named(m)) {
    const Estimate& e = *n.estimate;
    out += (n.section.empty() ? "" : n.section + ".") + n.name + "," +
           (n.policy ? CsvCell(n.policy->policy_id) : "") + "," + CsvNumber(e.value) + "," +
           CsvNumber(e.ci_low) + "," + CsvNumber(e.ci_high) + "," +
           std::to_string(e.resamples_defined) + "\n";
  }
  return out;
}

}  // namespace wm::metrics

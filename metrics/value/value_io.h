#pragma once
// Value metrics from and to files: the per-episode returns CSV in, JSON (schemas/
// value-metrics.schema.json) or CSV out. Formats: docs/metrics-value.md.
#include <nlohmann/json_fwd.hpp>
#include <string>

#include "metrics/value/value_metrics.h"

namespace wm::metrics {

// Reads `path` (header required, any column order, other columns ignored): episode, policy_id,
// real_return, model_return; then ComputeValueMetrics. Every input error is a wm::Error naming
// the file, the line and the column.
ValueMetrics ComputeValueMetricsFromCsv(const std::string& path, const BootstrapOptions& options);

// {"episodes", "policies", "bootstrap", "value_gap", "normalized_value_gap", "optimism",
//  "policy_ranking": {...}, "episode_correlation": {...}, "per_policy": [...]}; each metric is
// {"value", "ci_low", "ci_high", "resamples_defined"} with null for NaN.
nlohmann::json ValueMetricsToJson(const ValueMetrics& metrics);

// Columns metric,policy_id,value,ci_low,ci_high,resamples_defined; one row per metric (metric
// names as JSON paths: policy_ranking.pearson), per-policy rows carry their policy_id; an
// undefined value is an empty cell.
std::string ValueMetricsToCsv(const ValueMetrics& metrics);

}  // namespace wm::metrics

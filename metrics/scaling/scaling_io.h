#pragma once
// Scaling-law fits from and to files: the points CSV in, JSON (schemas/scaling-fit.schema.json)
// or CSV out. Formats: docs/metrics-value.md, "Scaling-law fit".
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "metrics/scaling/scaling_fit.h"

namespace wm::metrics {

struct ScalingReport {
  ScalingFitOptions options;
  std::vector<ScalingPoint> points;
  ScalingFit fit;
  std::vector<Prediction> fitted;         // the curve at each point's x, in point order
  std::vector<Prediction> extrapolation;  // at the requested x values, in request order
};

// Reads `path` (header required, any column order): x, y, optional label; fits; predicts at
// `extrapolate`. Every input error is a wm::Error naming the file and, for a bad point, its
// line and column.
ScalingReport FitScalingLawFromCsv(const std::string& path, const ScalingFitOptions& options,
                                   const std::vector<double>& extrapolate);

// {"form", "robust", "robust_scale", "bounds", "points", "dof", "parameters": {"a", "b", "c"},
//  "rss", "sigma2", "r2", "fit_space", "converged", "iterations", "termination", "at_bound",
//  "fitted": [...], "extrapolation": [...]}; null for NaN.
nlohmann::json ScalingReportToJson(const ScalingReport& report);

// Columns quantity,label,x,value,std_error: rows a, b, c, rss, sigma2, r2, then one "fitted" row
// per point and one "extrapolation" row per requested x.
std::string ScalingReportToCsv(const ScalingReport& report);

}  // namespace wm::metrics

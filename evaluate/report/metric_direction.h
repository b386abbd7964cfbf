#pragma once
// Which way is better for each metric wm-eval reports, and the headline metrics `wm-report
// compare` tabulates by default (docs/reports.md, "Metrics and their direction").
#include <optional>
#include <string>
#include <vector>

namespace wm::report {

enum class Direction { kHigherIsBetter, kLowerIsBetter };

// Higher: psnr, ssim, ms_ssim, pearson, spearman, kendall, ranking_accuracy,
// uncertainty_error_corr and the uncertainty signals' <signal>_error_pearson,
// <signal>_error_spearman and <signal>_auroc (wm-eval --retrace-ks). Lower: mse and every
// mse_<region>, lpips_style, fvd_style, value_gap, return_error. nullopt for anything else (e.g.
// the per-episode `uncertainty`, which has no better direction).
std::optional<Direction> MetricDirection(const std::string& metric);

// The default columns of `wm-report compare`, in output order (those no report has are dropped).
const std::vector<std::string>& HeadlineMetrics();

// "psnr, ssim, ..., mse_<region>, ...": the known metrics, for error messages and --help.
std::string KnownMetricsText();

}  // namespace wm::report

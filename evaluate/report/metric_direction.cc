#include "evaluate/report/metric_direction.h"

#include <map>

namespace wm::report {
namespace {

const std::map<std::string, Direction>& Directions() {
  using enum Direction;
  static const std::map<std::string, Direction> directions = {
      {"psnr", kHigherIsBetter},
      {"ssim", kHigherIsBetter},
      {"ms_ssim", kHigherIsBetter},
      {"pearson", kHigherIsBetter},
      {"spearman", kHigherIsBetter},
      {"kendall", kHigherIsBetter},
      {"ranking_accuracy", kHigherIsBetter},
      // A model whose sample spread tracks its error knows where it is wrong.
      {"uncertainty_error_corr", kHigherIsBetter},
      // Controllability (Genie's ΔtPSNR): PSNR lost when the actions are perturbed.
      {"delta_tpsnr", kHigherIsBetter},
      // Error to the truth over error to the start, where the scene moved: < 1 moved right.
      {"moved_error_ratio", kLowerIsBetter},
      {"mse", kLowerIsBetter},
      {"lpips", kLowerIsBetter},  // official LPIPS (wm-eval --lpips-weights)
      {"lpips_style", kLowerIsBetter},
      {"fvd_style", kLowerIsBetter},
      {"value_gap", kLowerIsBetter},
      {"return_error", kLowerIsBetter}};
  return directions;
}

}  // namespace

std::optional<Direction> MetricDirection(const std::string& metric) {
  const auto& directions = Directions();
  if (auto it = directions.find(metric); it != directions.end()) return it->second;
  // Segmented-region MSE (WPE eq. 3): mse_arm, mse_object, mse_background, any other region.
  if (metric.size() > 4 && metric.starts_with("mse_")) return Direction::kLowerIsBetter;
  // wm-eval --retrace-ks: how well an uncertainty signal tracks the error (docs/reports.md).
  for (const char* suffix : {"_error_pearson", "_error_spearman", "_auroc"}) {
    if (metric.ends_with(suffix) && metric.size() > std::string(suffix).size()) {
      return Direction::kHigherIsBetter;
    }
  }
  return std::nullopt;
}

const std::vector<std::string>& HeadlineMetrics() {
  static const std::vector<std::string> metrics = {"psnr",
                                                   "ssim",
                                                   "mse",
                                                   "lpips",
                                                   "lpips_style",
                                                   "fvd_style",
                                                   "mse_arm",
                                                   "mse_object",
                                                   "mse_background",
                                                   "delta_tpsnr",
                                                   "moved_error_ratio",
                                                   "value_gap",
                                                   "pearson",
                                                   "spearman",
                                                   "kendall",
                                                   "ranking_accuracy",
                                                   "return_error",
                                                   "uncertainty_error_corr"};
  return metrics;
}

std::string KnownMetricsText() {
  std::string text;
  for (const auto& [name, direction] : Directions()) text += (text.empty() ? "" : ", ") + name;
  return text + ", mse_<region>, <signal>_error_pearson, <signal>_error_spearman, <signal>_auroc";
}

}  // namespace wm::report

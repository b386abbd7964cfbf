#pragma once
// `wm-metrics scaling`: a scaling-law fit y = a x^-b + c (or log-linear) of loss against
// compute, parameters or data, with standard errors and extrapolation (docs/metrics-value.md).
namespace CLI {
class App;
}

namespace wm::metrics {

// Registers the `scaling` subcommand on `app`. It runs from its CLI11 callback during
// app.parse(); wm::Error escapes from parse() for main to report.
void AddScalingCommand(CLI::App& app);

}  // namespace wm::metrics

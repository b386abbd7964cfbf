#pragma once
// `wm-metrics value`: value gap, optimism and policy-ranking metrics with bootstrap intervals
// from a per-episode returns CSV (docs/metrics-value.md).
namespace CLI {
class App;
}

namespace wm::metrics {

// Registers the `value` subcommand on `app`. It runs from its CLI11 callback during
// app.parse(); wm::Error escapes from parse() for main to report.
void AddValueCommand(CLI::App& app);

}  // namespace wm::metrics

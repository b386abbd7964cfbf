#pragma once
// `wm-metrics seg`: segmented-region MSE (arm / object / background) between reference and
// predicted frames, with region maps from label files, motion or depth
// (docs/metrics-segmentation.md).
namespace CLI {
class App;
}

namespace wm::metrics {

// The one-line summary `wm-metrics --help` lists for `seg`.
inline constexpr const char* kSegCommandSummary =
    "Segmented-region MSE (arm / object / background) with label, motion or depth masks";

// Registers the `seg` subcommand on `app`. It runs from its CLI11 callback during app.parse();
// wm::Error escapes from parse() for main to report (exit 1).
void AddSegCommand(CLI::App& app);

}  // namespace wm::metrics

#pragma once
// `wm-report plot`: per-step, value and scaling plots via scripts/plot_report.py
// (evaluate/report/plot_launcher.h, docs/reports.md).
namespace CLI {
class App;
}

namespace wm::report {

// Registers the `plot` subcommand on `app`; on success its callback does not return (the process
// becomes the plot script); wm::Error escapes from parse() for main to report.
void AddPlotCommand(CLI::App& app);

}  // namespace wm::report

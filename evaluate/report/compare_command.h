#pragma once
// `wm-report compare`: checkpoints side by side with deltas to a baseline and ranks
// (evaluate/report/compare.h, docs/reports.md).
namespace CLI {
class App;
}

namespace wm::report {

// Registers the `compare` subcommand on `app`; it runs from its CLI11 callback during
// app.parse(), and wm::Error escapes from parse() for main to report.
void AddCompareCommand(CLI::App& app);

}  // namespace wm::report

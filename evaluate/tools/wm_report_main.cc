// wm-report: compare and plot the report directories wm-eval writes (docs/reports.md). One
// subcommand per task, each in evaluate/report/<name>_command.cc.
#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>

#include "core/log.h"
#include "core/provenance.h"
#include "evaluate/report/compare_command.h"
#include "evaluate/report/plot_command.h"

namespace {
constexpr const char* kFooter = R"(
Examples:
  wm-eval --checkpoint runs/dyn-a --checkpoint runs/dyn-b ... --out reports/
  wm-report compare reports/dyn-a reports/dyn-b --out compare.csv --markdown compare.md
  wm-report plot reports/dyn-a reports/dyn-b --out plots/

Formats of the report directories and of compare.csv: docs/reports.md.
Exit codes: 0 success, 1 bad input (one line naming the file, line and column), 2 usage.)";

// Parses the command line and runs the chosen subcommand inside app.parse().
int RunReport(int argc, char** argv) {
  CLI::App app{"wm-report: compare world-model checkpoints from their wm-eval reports, and plot"};
  app.footer(kFooter);
  app.set_version_flag("--version", wm::VersionString("wm-report"));
  app.require_subcommand(1);
  wm::report::AddCompareCommand(app);
  wm::report::AddPlotCommand(app);
  wm::InitLogging();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return RunReport(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "wm-report: error: " << e.what() << "\n";
    return 1;
  }
}

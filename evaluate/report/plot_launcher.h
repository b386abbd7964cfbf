#pragma once
// `wm-report plot` draws with matplotlib: scripts/plot_report.py does the drawing and this finds
// the script, the interpreter and wm-metrics (for the scaling-law fit) and hands over to it.
#include <string>
#include <vector>

namespace wm::report {

struct PlotOptions {
  std::vector<std::string> report_dirs;  // REPORT_DIR/<checkpoint> directories
  std::string out_dir;                   // where the PNGs (and the scaling fit) go
  std::vector<std::string> metrics;      // per-step metrics to plot; empty: every one
  std::string rollout = "all";           // rollout to draw, or all
  std::string scaling_metric = "mse";    // summary.csv metric plotted against manifest "scale"
  std::string scaling_rollout = "plain";
  std::string script;      // empty: FindPlotScript()
  std::string wm_metrics;  // empty: wm-metrics beside this executable, if any
  std::string python = "/usr/bin/python3";
};

// $WMKIT_SCRIPTS/plot_report.py; else scripts/plot_report.py in the first directory above the
// running executable that has it (build/bin/ -> ../../scripts); else the source tree this binary
// was built from; else "scripts/plot_report.py".
std::string FindPlotScript();

// The path of `tool` in the running executable's directory, or "" when there is none.
std::string SiblingTool(const std::string& tool);

// The full command line: python, script, options, report directories.
std::vector<std::string> PlotCommandLine(const PlotOptions& options);

// Replaces this process with the plot script (its exit code becomes ours). Throws wm::Error
// when the script or the interpreter is missing or cannot be started.
[[noreturn]] void ExecPlotScript(const PlotOptions& options);

}  // namespace wm::report

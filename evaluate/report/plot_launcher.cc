#include "evaluate/report/plot_launcher.h"

#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>

#include "core/error.h"
#include "core/paths.h"

#ifndef WM_REPORT_SOURCE_DIR
#define WM_REPORT_SOURCE_DIR ""
#endif

namespace wm::report {
namespace fs = std::filesystem;
namespace {

constexpr const char* kScript = "scripts/plot_report.py";

std::string Join(const std::vector<std::string>& items) {
  std::string text;
  for (const auto& s : items) text += (text.empty() ? "" : ",") + s;
  return text;
}

}  // namespace

std::string FindPlotScript() {
  if (const char* env = std::getenv("WMKIT_SCRIPTS"); env != nullptr && *env != '\0') {
    return (fs::path(env) / "plot_report.py").string();
  }
  for (fs::path dir = wm::ExecutableDir(); !dir.empty() && dir != dir.root_path();
       dir = dir.parent_path()) {
    if (fs::is_regular_file(dir / kScript)) return (dir / kScript).string();
  }
  const fs::path built_from = fs::path(WM_REPORT_SOURCE_DIR) / kScript;
  if (!std::string(WM_REPORT_SOURCE_DIR).empty() && fs::is_regular_file(built_from)) {
    return built_from.string();
  }
  return kScript;
}

std::string SiblingTool(const std::string& tool) {
  const fs::path dir = wm::ExecutableDir();
  if (dir.empty() || !fs::is_regular_file(dir / tool)) return "";
  return (dir / tool).string();
}

std::vector<std::string> PlotCommandLine(const PlotOptions& o) {
  const std::string script = o.script.empty() ? FindPlotScript() : o.script;
  std::vector<std::string> args = {o.python,           script,           "--out",
                                   o.out_dir,          "--rollout",      o.rollout,
                                   "--scaling-metric", o.scaling_metric, "--scaling-rollout",
                                   o.scaling_rollout};
  if (!o.metrics.empty()) args.insert(args.end(), {"--metrics", Join(o.metrics)});
  const std::string wm_metrics = o.wm_metrics.empty() ? SiblingTool("wm-metrics") : o.wm_metrics;
  if (!wm_metrics.empty()) args.insert(args.end(), {"--wm-metrics", wm_metrics});
  args.push_back("--");
  args.insert(args.end(), o.report_dirs.begin(), o.report_dirs.end());
  return args;
}

void ExecPlotScript(const PlotOptions& o) {
  const std::vector<std::string> args = PlotCommandLine(o);
  Check(fs::is_regular_file(args[1]), "plot script not found (give --script)", {.file = args[1]});
  Check(access(args[0].c_str(), X_OK) == 0, "python interpreter not found or not executable",
        {.file = args[0]});
  std::vector<char*> argv;
  argv.reserve(args.size() + 1);
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  std::cout.flush();
  execv(argv[0], argv.data());
  throw Error(std::string("cannot start: ") + std::strerror(errno), {.file = args[0]});
}

}  // namespace wm::report

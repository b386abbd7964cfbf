// wm-metrics: frame metrics between reference and predicted images, folders or videos (no
// subcommand), and one subcommand per further metrics family, each in tools/<name>_command.cc.
// This is the light program: it links no LibTorch, OpenCV codecs or PCL, and hands what needs
// them to wm-metrics-full (tools/wm_metrics_cli.h).
#include <CLI/CLI.hpp>

#include "metrics/tools/full_program.h"
#include "metrics/tools/seg_command.h"
#include "metrics/tools/wm_metrics_cli.h"

namespace {

// `seg` as --help lists it; the command itself runs in wm-metrics-full.
void AddSegStandIn(CLI::App& app) { app.add_subcommand("seg", wm::metrics::kSegCommandSummary); }

}  // namespace

int main(int argc, char** argv) {
  wm::metrics::MetricsProgram light{.add_seg_command = AddSegStandIn};
  light.hand_over = [argv] { wm::metrics::HandOverToFullProgram(argv); };
  return wm::metrics::RunWmMetrics(argc, argv, light);
}

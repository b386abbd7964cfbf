#pragma once
// The wm-metrics command line, shared by the two programs behind that name (docs/metrics.md,
// "Two programs"): wm-metrics, light (no LibTorch, no OpenCV codecs, no PCL: it starts in a few
// milliseconds), runs the pixel metrics on PNG and JPEG frames and the value and scaling
// subcommands, and hands every other command, unchanged, to wm-metrics-full, which links all of
// it. Both parse the same options, so help, output and exit codes are the same whichever runs.
#include <functional>

#include "metrics/compare.h"

namespace CLI {
class App;
}

namespace wm::metrics {

struct MetricsProgram {
  LpipsLoader lpips_loader;             // lpips; empty in the light program
  FeatureNetLoader feature_net_loader;  // lpips_style / fvd_style; empty in the light program
  // `seg`: the command, or the light program's stand-in that only --help lists
  void (*add_seg_command)(CLI::App&) = nullptr;
  // The light program: replaces this process with wm-metrics-full, same arguments; throws
  // wm::Error when it cannot. Called for `seg`, learned metrics and NeedsFullDecoder. Empty in
  // wm-metrics-full.
  std::function<void()> hand_over;
};

// The whole program: parses argv, runs, prints; returns the exit code (docs/metrics.md).
int RunWmMetrics(int argc, char** argv, const MetricsProgram& program);

}  // namespace wm::metrics

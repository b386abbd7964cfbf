#pragma once
// How the light wm-metrics hands a command to wm-metrics-full (metrics/tools/wm_metrics_cli.h).

namespace wm::metrics {

inline constexpr const char* kFullProgram = "wm-metrics-full";

// Replaces this process with wm-metrics-full from this executable's folder, given the same argv
// (argv[0] too, so that usage messages name the program as it was called). Returns only by
// throwing wm::Error, naming the path, when the program is missing or cannot start.
[[noreturn]] void HandOverToFullProgram(char** argv);

}  // namespace wm::metrics

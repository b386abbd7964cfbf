#pragma once
// Where the shipped configs live: $WMKIT_CONFIGS, else <repo>/configs found relative to the
// running executable (build/bin/ -> ../../configs), else ./configs.
#include <string>

namespace wm {

std::string DefaultConfigsDir();

// The folder of the running executable (from /proc/self/exe); "" where that cannot be read.
// Tools find their siblings here (wm-report: wm-metrics; wm-metrics: wm-metrics-full).
std::string ExecutableDir();

// Every run directory keeps its model in this file (tokenizer and dynamics runs alike).
inline constexpr const char* kCheckpointFile = "checkpoint.wmt";

// A run directory -> its checkpoint.wmt; any other path is taken as the checkpoint file itself.
std::string CheckpointFileIn(const std::string& run_dir_or_file);

}  // namespace wm

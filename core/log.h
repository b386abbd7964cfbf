#pragma once
// Logging: spdlog to stderr, one format for every tool. Levels: trace debug info warn error.
// spdlog stays out of this header: LibTorch 2.x ships its own fmt headers, which shadow the fmt
// that the system's spdlog was built with, so a file that includes torch logs through LogInfo.
#include <string>

namespace wm {

// Sets the global level ("info" default; "debug" with --verbose) and the line format.
void InitLogging(const std::string& level = "info");

// One line at info / warn level (spdlog, for files that include torch).
void LogInfo(const std::string& message);
void LogWarn(const std::string& message);

}  // namespace wm

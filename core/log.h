#pragma once
// Logging: spdlog to stderr, one format for every tool. Levels: trace debug info warn error.
#include <spdlog/spdlog.h>

#include <string>

namespace wm {

// Sets the global level ("info" default; "debug" with --verbose) and the line format.
void InitLogging(const std::string& level = "info");

}  // namespace wm

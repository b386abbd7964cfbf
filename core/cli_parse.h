#pragma once
// One exit-code convention for every wmkit tool's command line: 0 after --help / --version, 2 for
// a bad command line (CLI11's message on stderr), whatever CLI11's own error code.
#include <CLI/CLI.hpp>

namespace wm {

inline constexpr int kUsageExitCode = 2;

// Parses argv into `app` (running subcommand callbacks). Returns -1 to go on, else the exit code.
inline int ParseCommandLine(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
    return -1;
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : kUsageExitCode;  // --help is a ParseError too
  }
}

}  // namespace wm

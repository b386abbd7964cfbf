// seg_command_tool: the `wm-metrics seg` subcommand alone (seg_command_tool seg --ref ...), so
// that test_segmented_mse_reference.py checks exactly the command wm-metrics registers, built
// and tested independently of the other subcommands.
#include <CLI/CLI.hpp>
#include <iostream>

#include "metrics/tools/seg_command.h"

int main(int argc, char** argv) {
  CLI::App app{"seg_command_tool: `wm-metrics seg` for the reference tests"};
  wm::metrics::AddSegCommand(app);
  app.require_subcommand(1);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    std::cerr << e.what() << "\n";  // wm-metrics prints the same line through spdlog
    return 1;
  }
  return 0;
}

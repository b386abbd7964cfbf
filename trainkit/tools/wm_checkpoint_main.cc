// wm-checkpoint: move checkpoint weights to and from safetensors files, the format PyTorch and
// Hugging Face tools read (docs/safetensors.md). Torch-free: links only wm_core.
// Exit codes: 0 success, 1 a wmkit error (bad file, tensor mismatch), 2 a bad command line.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>

#include "core/checkpoint_safetensors.h"
#include "core/cli_parse.h"
#include "core/log.h"
#include "core/provenance.h"

namespace {

CLI::App* AddExport(CLI::App& app, wm::SafetensorsExportOptions& o) {
  CLI::App* cmd = app.add_subcommand("export", "Write a checkpoint's tensors as safetensors");
  cmd->footer(
      "Example:\n  wm-checkpoint export --checkpoint runs/dyn-tiny --out dyn-tiny.safetensors\n"
      "Without --all only the model/ tensors are written, named without the prefix (the\n"
      "PyTorch state_dict names); __metadata__[\"wmkit\"] holds the checkpoint's meta JSON.");
  cmd->add_option("--checkpoint", o.checkpoint, "Run directory or checkpoint .wmt file")
      ->required()
      ->check(CLI::ExistingPath);
  cmd->add_option("--out", o.out, "The .safetensors file to write")->required();
  cmd->add_flag("--all", o.all_tensors,
                "Every tensor (optimizer state too) under its archive name");
  return cmd;
}

CLI::App* AddImport(CLI::App& app, wm::SafetensorsImportOptions& o) {
  CLI::App* cmd =
      app.add_subcommand("import", "Put a safetensors file's weights into a checkpoint");
  cmd->footer(
      "Example:\n  wm-checkpoint import --safetensors tuned.safetensors --like runs/dyn-tiny \\\n"
      "    --out tuned.wmt\n"
      "The file must have exactly the tensors `export` writes for --like (same names, dtypes\n"
      "and shapes); --like's other tensors and meta are kept. --out is written atomically.");
  cmd->add_option("--safetensors", o.safetensors, "The .safetensors file to read")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--like", o.like, "Run directory or .wmt whose layout and meta to keep")
      ->required()
      ->check(CLI::ExistingPath);
  cmd->add_option("--out", o.out, "The new checkpoint .wmt file")->required();
  cmd->add_flag("--all", o.all_tensors, "The file holds every tensor (from `export --all`)");
  return cmd;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"wm-checkpoint: checkpoints <-> safetensors (PyTorch, Hugging Face)"};
  app.set_version_flag("--version", wm::VersionString("wm-checkpoint"));
  app.footer(
      "Exit codes: 0 success, 1 error (one line naming file and tensor), 2 bad command line.");
  wm::SafetensorsExportOptions export_options;
  wm::SafetensorsImportOptions import_options;
  CLI::App* export_cmd = AddExport(app, export_options);
  CLI::App* import_cmd = AddImport(app, import_options);
  app.require_subcommand(1);
  if (const int rc = wm::ParseCommandLine(app, argc, argv); rc >= 0) return rc;
  wm::InitLogging();
  try {
    if (export_cmd->parsed()) {
      const size_t n = wm::ExportCheckpointSafetensors(export_options);
      spdlog::info("wrote {} tensors to {}", n, export_options.out);
    } else if (import_cmd->parsed()) {
      const size_t n = wm::ImportCheckpointSafetensors(import_options);
      spdlog::info("replaced {} tensors; wrote {}", n, import_options.out);
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "wm-checkpoint: error: " << e.what() << "\n";
    return 1;
  }
}

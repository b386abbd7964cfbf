#include "metrics/tools/wm_metrics_cli.h"

#include <CLI/CLI.hpp>
#include <cstring>
#include <iostream>

#include "core/cli_parse.h"
#include "core/log.h"
#include "core/malloc_tuning.h"
#include "core/provenance.h"
#include "metrics/image_io.h"
#include "metrics/tools/scaling_command.h"
#include "metrics/tools/value_command.h"

namespace wm::metrics {
namespace {

constexpr const char* kFooter = R"(
Examples:
  wm-metrics --ref real.png --pred imagined.png
  wm-metrics --ref real_frames/ --pred rollout_frames/ --metrics psnr,ssim,ms_ssim --per-frame
  wm-metrics --ref real.mp4 --pred rollout.mp4 --metrics psnr,lpips --lpips-weights lpips_alex.wmt --format csv
  wm-metrics --ref real.mp4 --pred rollout.mp4 --metrics lpips_style,fvd_style --feature-net runs/tok-tiny
  wm-metrics value --returns returns.csv          # value gap, policy ranking (value --help)
  wm-metrics scaling --points losses.csv          # scaling-law fit (scaling --help)

Folders are paired by sorted file name; videos frame by frame. JSON output is one object with a
key per metric ({"psnr": 31.2, "ssim": 0.912, ...}); PSNR of identical frames is "inf".
Definitions: docs/metrics.md, docs/metrics-lpips.md, docs/metrics-value.md.
Exit codes: 0 success, 1 unreadable input, mismatched sizes or counts (message names the file), 2 usage.)";

// The frame comparison's options (no subcommand); returns --ref and --pred.
std::pair<CLI::Option*, CLI::Option*> AddCompareOptions(CLI::App& app, CompareOptions& o,
                                                        std::string& format) {
  CLI::Option* ref = app.add_option("--ref", o.ref, "Reference: image, folder of frames or video");
  CLI::Option* pred =
      app.add_option("--pred", o.pred, "Prediction: image, folder of frames or video");
  app.add_option("--metrics", o.metrics,
                 "Comma-separated: mse,psnr,ssim,ms_ssim,lpips,lpips_style,fvd_style")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--lpips-weights", o.lpips_weights, "LPIPS weights (wmkit tensor archive)");
  app.add_option("--mask", o.mask,
                 "mse/psnr/ssim inside a mask (non-zero pixels): one image, or a folder or video "
                 "with one mask per frame");
  app.add_option("--feature-net", o.feature_net,
                 "lpips_style / fvd_style features: a wm-tokenize run or checkpoint");
  app.add_option("--clip-length", o.clip_length, "fvd_style: frames per clip")
      ->capture_default_str();
  app.add_option("--device", o.device, "LPIPS / feature-net device: cpu, cuda, cuda:N")
      ->capture_default_str();
  app.add_option("--threads", o.threads, "Worker threads (0: all cores)")->capture_default_str();
  app.add_option("--chunk-frames", o.chunk_frames,
                 "Frame pairs held in memory at a time (long folders and videos stream)")
      ->capture_default_str();
  app.add_flag("--per-frame", o.per_frame, "Also print every frame's values");
  app.add_option("--format", format, "json or csv")
      ->check(CLI::IsMember({"json", "csv"}))
      ->capture_default_str();
  return {ref, pred};
}

// Frame comparison (no subcommand) needs --ref and --pred; they cannot be CLI11-required, which
// would demand them of every subcommand too, so the same error is raised here.
void RequireOptions(const CLI::App& app, std::initializer_list<const char*> names) {
  for (const char* name : names) {
    if (app.count(name) == 0) throw CLI::RequiredError(name);
  }
}

// The light program links no `seg` (PCL, OpenCV): any argument spelled "seg" sends the command
// to wm-metrics-full before parsing. One that is a file name instead costs only the slower start.
bool NamesSegCommand(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "seg") == 0) return true;
  }
  return false;
}

// The frame comparison, handed over where the light program cannot run it exactly.
nlohmann::json Compare(const CompareOptions& o, const MetricsProgram& program) {
  if (!program.hand_over) return CompareFrameSets(o);
  if (NeedsLearnedNetwork(o)) program.hand_over();
  try {
    return CompareFrameSets(o);
  } catch (const NeedsFullDecoder&) {
    program.hand_over();
    throw;  // not reached: hand_over starts wm-metrics-full or throws
  }
}

}  // namespace

int RunWmMetrics(int argc, char** argv, const MetricsProgram& program) {
  CompareOptions o;
  o.lpips_loader = program.lpips_loader;
  o.feature_net_loader = program.feature_net_loader;
  std::string format = "json";
  CLI::App app{
      "wm-metrics: PSNR, SSIM, MS-SSIM, MSE and LPIPS between frames; value and scaling metrics "
      "as subcommands"};
  app.footer(kFooter);
  app.set_version_flag("--version", wm::VersionString("wm-metrics"));
  const auto [ref, pred] = AddCompareOptions(app, o, format);
  AddValueCommand(app);
  AddScalingCommand(app);
  program.add_seg_command(app);
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
    sub->excludes(ref)->excludes(pred);
  }
  wm::InitLogging("warn");
  // Every frame is a few MB of doubles: glibc would map and unmap each one, page faults included
  // (a sixth of a 120-pair folder comparison's CPU time).
  wm::KeepLargeAllocationsInHeap();
  try {
    if (program.hand_over && NamesSegCommand(argc, argv)) program.hand_over();
    app.parse(argc, argv);  // a subcommand runs in here
    if (!app.get_subcommands().empty()) return 0;
    RequireOptions(app, {"--ref", "--pred"});
    const nlohmann::json result = Compare(o, program);
    std::cout << (format == "json" ? result.dump(2) + "\n" : FormatCsv(result, o.metrics));
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : wm::kUsageExitCode;
  } catch (const std::exception& e) {
    std::cerr << "wm-metrics: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace wm::metrics

// wm-metrics: frame metrics between reference and predicted images, folders or videos.
#include <CLI/CLI.hpp>
#include <iostream>

#include "core/error.h"
#include "core/log.h"
#include "core/provenance.h"
#include "metrics/compare.h"

namespace {
constexpr const char* kFooter = R"(
Examples:
  wm-metrics --ref real.png --pred imagined.png
  wm-metrics --ref real_frames/ --pred rollout_frames/ --metrics psnr,ssim,ms_ssim --per-frame
  wm-metrics --ref real.mp4 --pred rollout.mp4 --metrics psnr,lpips --lpips-weights lpips_alex.wmt --format csv

Folders are paired by sorted file name; videos frame by frame. JSON output is one object with a
key per metric ({"psnr": 31.2, "ssim": 0.912, ...}); PSNR of identical frames is "inf".
Definitions: docs/metrics.md, docs/metrics-lpips.md.
Exit codes: 0 success, 1 unreadable input, mismatched sizes or counts (message names the file), 2 usage.)";
}  // namespace

int main(int argc, char** argv) {
  wm::metrics::CompareOptions o;
  std::string format = "json";
  CLI::App app{"wm-metrics: PSNR, SSIM, MS-SSIM, MSE and LPIPS between frames"};
  app.footer(kFooter);
  app.set_version_flag("--version", wm::VersionString("wm-metrics"));
  app.add_option("--ref", o.ref, "Reference: image, folder of frames or video")->required();
  app.add_option("--pred", o.pred, "Prediction: image, folder of frames or video")->required();
  app.add_option("--metrics", o.metrics, "Comma-separated: mse,psnr,ssim,ms_ssim,lpips")
      ->delimiter(',')->capture_default_str();
  app.add_option("--lpips-weights", o.lpips_weights, "LPIPS weights (wmkit tensor archive)");
  app.add_option("--device", o.device, "LPIPS device: cpu, cuda, cuda:N")->capture_default_str();
  app.add_option("--threads", o.threads, "Worker threads (0: all cores)")->capture_default_str();
  app.add_flag("--per-frame", o.per_frame, "Also print every frame's values");
  app.add_option("--format", format, "json or csv")->check(CLI::IsMember({"json", "csv"}))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  wm::InitLogging("warn");
  try {
    nlohmann::json result = wm::metrics::CompareFrameSets(o);
    std::cout << (format == "json" ? result.dump(2) + "\n"
                                   : wm::metrics::FormatCsv(result, o.metrics));
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}

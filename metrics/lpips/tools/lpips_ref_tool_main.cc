// lpips_ref_tool: LPIPS (v0.1, AlexNet) of image pairs, printed as JSON. The reference checks
// (tests/metrics/lpips/) and bench/lpips_bench.py drive wm::metrics::Lpips through it.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/log.h"
#include "core/provenance.h"
#include "metrics/lpips/lpips.h"
#include "metrics/lpips/tools/npy_io.h"

namespace {

constexpr const char* kFooter = R"(
Inputs: .npy arrays [N, H, W, 3] of uint8 RGB, or of float32 RGB already in [-1, 1]; or raw
interleaved RGB uint8 files (any other extension) with --size HxW, N = bytes / (H * W * 3).
Pair i is (A[i], B[i]). uint8 maps to [-1, 1] as x / 127.5 - 1.

Prints one JSON object: {"pairs", "height", "width", "distances": [...], "layers": [[5]...]
(with --per-layer), "seconds", "pairs_per_second"}. "seconds" is the mean over --repeat timed
passes after one untimed warm-up pass, or the single pass when --repeat is 0.
--features-dir DIR also writes DIR/relu{1..5}.npy, float32 [N, C, h, w]: AlexNet relu1..relu5
of the A images before normalisation (for checking the layer taps against torchvision).

Example:
  python3 scripts/export_lpips_weights.py --random-seed 0 --out /tmp/lpips-rand.wmt
  lpips_ref_tool --weights /tmp/lpips-rand.wmt --a pred.npy --b truth.npy --per-layer

Weights format: docs/metrics-lpips.md.
Exit codes: 0 success, 1 bad input or weights (message names file and tensor), 2 usage.)";

struct Images {
  bool is_float = false;
  int64_t count = 0;
  int height = 0, width = 0;
  std::string bytes;
  std::vector<const uint8_t*> U8() const {
    std::vector<const uint8_t*> v;
    for (int64_t i = 0; i < count; ++i) {
      v.push_back(reinterpret_cast<const uint8_t*>(bytes.data()) + i * height * width * 3);
    }
    return v;
  }
  std::vector<const float*> F32() const {
    std::vector<const float*> v;
    for (int64_t i = 0; i < count; ++i) {
      v.push_back(reinterpret_cast<const float*>(bytes.data()) + i * height * width * 3);
    }
    return v;
  }
};

Images LoadImages(const std::string& path, const std::string& size) {
  Images im;
  if (std::filesystem::path(path).extension() == ".npy") {
    wm::npy::Array a = wm::npy::Read(path);
    wm::Check(a.shape.size() == 4 && a.shape[3] == 3, "expected an [N, H, W, 3] array",
              {.file = path});
    wm::Check(a.descr == "|u1" || a.descr == "<f4", "expected uint8 or float32 images",
              {.file = path});
    im.is_float = a.descr == "<f4";
    im.count = a.shape[0];
    im.height = static_cast<int>(a.shape[1]);
    im.width = static_cast<int>(a.shape[2]);
    im.bytes = std::move(a.bytes);
    return im;
  }
  wm::Check(std::sscanf(size.c_str(), "%dx%d", &im.height, &im.width) == 2 && im.height > 0 &&
                im.width > 0,
            "raw RGB input needs --size HxW", {.file = path});
  im.bytes = wm::ReadFile(path);
  const int64_t frame = int64_t{im.height} * im.width * 3;
  wm::Check(
      im.bytes.size() % frame == 0,
      std::to_string(im.bytes.size()) + " bytes is not a whole number of " + size + " RGB frames",
      {.file = path});
  im.count = static_cast<int64_t>(im.bytes.size()) / frame;
  return im;
}

void WriteFeatures(wm::metrics::Lpips& lpips, const Images& a, const std::string& dir) {
  wm::Check(!a.is_float, "--features-dir needs uint8 images");
  std::filesystem::create_directories(dir);
  std::vector<std::vector<float>> stacked(wm::metrics::kLpipsLayers);
  std::vector<std::array<int64_t, 3>> shapes(wm::metrics::kLpipsLayers);
  for (const uint8_t* image : a.U8()) {
    const auto maps = lpips.Features(image, a.height, a.width);
    for (int l = 0; l < wm::metrics::kLpipsLayers; ++l) {
      stacked[l].insert(stacked[l].end(), maps[l].data.begin(), maps[l].data.end());
      shapes[l] = maps[l].shape;
    }
  }
  for (int l = 0; l < wm::metrics::kLpipsLayers; ++l) {
    wm::npy::Write(dir + "/relu" + std::to_string(l + 1) + ".npy", "<f4",
                   {a.count, shapes[l][0], shapes[l][1], shapes[l][2]}, stacked[l].data(),
                   stacked[l].size() * sizeof(float));
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::string weights, path_a, path_b, size, features_dir;
  wm::metrics::LpipsOptions options;
  int repeat = 0;
  bool per_layer = false;
  CLI::App app{"lpips_ref_tool: LPIPS v0.1 (AlexNet) distances of image pairs, as JSON"};
  app.footer(kFooter);
  app.set_version_flag("--version", wm::VersionString("lpips_ref_tool"));
  app.add_option("--weights", weights, "LPIPS weights archive (WMTENSR1)")->required();
  app.add_option("--a", path_a, "First images of each pair (.npy or raw RGB)")->required();
  app.add_option("--b", path_b, "Second images of each pair (.npy or raw RGB)")->required();
  app.add_option("--size", size, "HxW of raw RGB inputs");
  app.add_option("--device", options.device, "Torch device")->capture_default_str();
  app.add_option("--batch-size", options.batch_size, "Pairs per forward pass")
      ->capture_default_str();
  app.add_option("--threads", options.threads, "Torch intra-op threads (0: torch default)")
      ->capture_default_str();
  app.add_option("--repeat", repeat, "Timed passes after one warm-up pass (0: a single pass)")
      ->capture_default_str();
  app.add_flag("--per-layer", per_layer, "Also print the relu1..relu5 terms of each pair");
  app.add_option("--features-dir", features_dir, "Write relu1..5 of the A images as .npy here");
  CLI11_PARSE(app, argc, argv);
  wm::InitLogging("info");
  try {
    wm::Check(repeat >= 0, "--repeat must be >= 0");
    const Images a = LoadImages(path_a, size), b = LoadImages(path_b, size);
    wm::Check(a.count == b.count && a.height == b.height && a.width == b.width &&
                  a.is_float == b.is_float,
              "--a and --b differ in count, size or dtype");
    wm::metrics::Lpips lpips(weights, options);
    auto pass = [&] {
      return a.is_float ? lpips.DistanceFloat(a.F32(), b.F32(), a.height, a.width)
                        : lpips.Distance(a.U8(), b.U8(), a.height, a.width);
    };
    std::vector<double> distances;
    if (repeat > 0) distances = pass();  // warm-up: allocator, oneDNN primitive caches
    const auto start = std::chrono::steady_clock::now();
    for (int r = 0; r < std::max(repeat, 1); ++r) distances = pass();
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() /
        std::max(repeat, 1);
    nlohmann::json out = {
        {"pairs", a.count},   {"height", a.height},
        {"width", a.width},   {"distances", distances},
        {"seconds", seconds}, {"pairs_per_second", seconds > 0 ? a.count / seconds : 0.0}};
    if (per_layer && !a.is_float) {
      out["layers"] = lpips.LayerDistances(a.U8(), b.U8(), a.height, a.width);
    }
    if (!features_dir.empty()) WriteFeatures(lpips, a, features_dir);
    std::cout << out.dump() << "\n";
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}

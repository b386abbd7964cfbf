// metrics_bench: SSIM + PSNR (optionally MS-SSIM) pairs per second of wm_metrics, timed from
// uint8 buffers in memory to metric values, best of --repeats runs. Pairs come from a raw file
// (count x 2 x H x W x C uint8: a then b; metrics_bench.py writes one) or are generated.
//   metrics_bench --pairs pairs.u8 --count 64 --height 256 --width 256 --channels 3 --json
#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "core/error.h"
#include "metrics/pixel_metrics.h"

namespace {
using Clock = std::chrono::steady_clock;
namespace wmm = wm::metrics;

struct Shape {
  int count = 64, height = 256, width = 256, channels = 3;
  size_t frame_bytes() const { return size_t(height) * width * channels; }
};

// Smooth random frames and noisy copies of them: SSIM well inside (0, 1).
std::vector<uint8_t> GeneratePairs(const Shape& s, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0, 12);
  std::vector<uint8_t> data(2 * s.count * s.frame_bytes());
  for (int i = 0; i < s.count; ++i) {
    uint8_t* a = &data[2 * i * s.frame_bytes()];
    uint8_t* b = a + s.frame_bytes();
    const double fx = 0.02 + 0.01 * (i % 7), fy = 0.03 + 0.01 * (i % 5);
    for (size_t p = 0; p < s.frame_bytes(); ++p) {
      const size_t pixel = p / s.channels, y = pixel / s.width, x = pixel % s.width;
      const double v = 128 + 100 * std::sin(fx * x + p % s.channels) * std::cos(fy * y);
      a[p] = static_cast<uint8_t>(std::clamp(v, 0.0, 255.0));
      b[p] = static_cast<uint8_t>(std::clamp(std::round(v + noise(rng)), 0.0, 255.0));
    }
  }
  return data;
}

std::vector<uint8_t> ReadPairs(const std::string& path, const Shape& s) {
  std::ifstream in(path, std::ios::binary);
  wm::Check(in.good(), "cannot open", {.file = path});
  std::vector<uint8_t> data(2 * s.count * s.frame_bytes());
  in.read(reinterpret_cast<char*>(data.data()), static_cast<std::streamsize>(data.size()));
  wm::Check(in.gcount() == static_cast<std::streamsize>(data.size()),
            "holds fewer bytes than --count pairs of --height x --width x --channels",
            {.file = path});
  return data;
}

// One timed pass: uint8 buffers -> Images -> metrics of every pair, pairs spread over
// `threads` workers (as scikit-image would be given uint8 arrays and convert them itself).
std::vector<wmm::FrameMetrics> RunOnce(const std::vector<uint8_t>& data, const Shape& s,
                                       const wmm::MetricOptions& options, int threads) {
  std::vector<wmm::FrameMetrics> out(s.count);
  std::atomic<int> next{0};
  auto work = [&] {
    wmm::MetricOptions single = options;
    single.threads = 1;
    // Pixels are refilled in place: fresh 1.5 MB buffers per pair would spend a third of the
    // time in page faults, which says nothing about the metrics.
    wmm::Image a = wmm::Image::FromUint8(data.data(), s.height, s.width, s.channels), b = a;
    for (int i = next++; i < s.count; i = next++) {
      const uint8_t* pa = &data[2 * i * s.frame_bytes()];
      a.pixels.assign(pa, pa + s.frame_bytes());
      b.pixels.assign(pa + s.frame_bytes(), pa + 2 * s.frame_bytes());
      out[i] = wmm::CompareFrame(a, b, single);
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  Shape shape;
  std::string pairs_path;
  int repeats = 5;
  bool json = false;
  wmm::MetricOptions options;
  options.ms_ssim = false;
  CLI::App app{"metrics_bench: SSIM + PSNR pairs/s of wm_metrics on uint8 frame pairs"};
  app.add_option("--pairs", pairs_path, "raw uint8 file: count x 2 x H x W x C (else generated)");
  app.add_option("--count", shape.count, "pairs")->capture_default_str();
  app.add_option("--height", shape.height)->capture_default_str();
  app.add_option("--width", shape.width)->capture_default_str();
  app.add_option("--channels", shape.channels)->capture_default_str();
  app.add_option("--threads", options.threads, "0 = all hardware threads")->capture_default_str();
  app.add_option("--repeats", repeats, "best of this many passes")->capture_default_str();
  app.add_flag("--ms-ssim", options.ms_ssim, "also time MS-SSIM");
  app.add_flag("--json", json, "one JSON line instead of text");
  CLI11_PARSE(app, argc, argv);

  try {
    const auto data = pairs_path.empty() ? GeneratePairs(shape, 1) : ReadPairs(pairs_path, shape);
    const int threads = options.threads > 0 ? options.threads
                                            : static_cast<int>(std::thread::hardware_concurrency());
    double best = 1e30;
    std::vector<wmm::FrameMetrics> results;
    for (int r = 0; r < repeats; ++r) {
      const auto start = Clock::now();
      results = RunOnce(data, shape, options, threads);
      best = std::min(best, std::chrono::duration<double>(Clock::now() - start).count());
    }
    const wmm::FrameMetrics mean = wmm::MeanMetrics(results);
    const double rate = shape.count / best;
    if (json) {
      nlohmann::json out = {{"pairs", shape.count},
                            {"threads", threads},
                            {"seconds", best},
                            {"pairs_per_s", rate},
                            {"mean", wmm::ToJson(mean)}};
      std::cout << out.dump() << "\n";
    } else {
      std::printf("%d pairs of %dx%dx%d, %d threads: %.1f pairs/s (%.3f ms/pair); mean SSIM %.6f\n",
                  shape.count, shape.height, shape.width, shape.channels, threads, rate,
                  1e3 * best / shape.count, mean.ssim);
    }
  } catch (const wm::Error& e) {
    std::fprintf(stderr, "metrics_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}

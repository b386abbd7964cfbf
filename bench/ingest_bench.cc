// Ingest throughput beside its bound: decoding the same JPEG bytes with OpenCV (same threads,
// same run). Prints MB/s, frames/s and the ratio; best of --repeats runs each.
#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <thread>

#include "core/log.h"
#include "core/paths.h"
#include "ingest/ingest_options.h"
#include "ingest/rlds/rlds_source.h"
#include "ingest/rlds/tfds_dataset.h"

namespace {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point a) {
  return std::chrono::duration<double>(Clock::now() - a).count();
}

// Decodes every frame once with `threads` workers; returns seconds.
double DecodeAll(const std::vector<std::string>& frames, int threads) {
  auto start = Clock::now();
  std::atomic<size_t> next{0};
  auto work = [&] {
    for (size_t i = next++; i < frames.size(); i = next++) {
      cv::Mat buf(1, static_cast<int>(frames[i].size()), CV_8U,
                  const_cast<char*>(frames[i].data()));
      if (cv::imdecode(buf, cv::IMREAD_UNCHANGED).empty()) std::abort();
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  return Seconds(start);
}

double IngestOnce(wm::ingest::IngestOptions o, const std::string& out, bool full_check) {
  fs::remove_all(out);
  o.output = out;
  o.full_image_check = full_check;
  auto start = Clock::now();
  wm::ingest::RunIngest(o);
  return Seconds(start);
}

}  // namespace

int main(int argc, char** argv) {
  std::string input, split = "train", work = "/tmp/wmkit-ingest-bench";
  int threads = 2, repeats = 3;
  CLI::App app{"ingest_bench: wm-ingest throughput vs the OpenCV JPEG-decode bound"};
  app.add_option("--input", input, "RLDS version directory")->required();
  app.add_option("--split", split);
  app.add_option("--threads", threads)->capture_default_str();
  app.add_option("--repeats", repeats)->capture_default_str();
  app.add_option("--work", work, "Scratch directory")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  wm::InitLogging("warn");

  wm::ingest::RldsSource source(input, split, "", wm::DefaultConfigsDir());
  // Every encoded stream (camera, depth, labels), as ingest checks them.
  std::vector<std::string> frames;
  for (const auto& ref : source.ListEpisodes(nullptr)) {
    wm::Episode e = source.Load(ref);
    for (auto& [name, f] : e.images) frames.insert(frames.end(), f.frames.begin(), f.frames.end());
  }
  double input_mb = 0;
  for (const auto& file : wm::rlds::OpenTfdsDataset(input).SplitFiles(split)) {
    input_mb += static_cast<double>(fs::file_size(file)) / 1e6;
  }

  wm::ingest::IngestOptions o;
  o.format = "rlds", o.input = input, o.split = split, o.threads = threads, o.shard_size_mb = 64;
  double decode = 1e30, full = 1e30, pass = 1e30;
  for (int r = 0; r < repeats; ++r) {
    decode = std::min(decode, DecodeAll(frames, threads));
    full = std::min(full, IngestOnce(o, work + "/full", true));
    pass = std::min(pass, IngestOnce(o, work + "/pass", false));
  }
  fs::remove_all(work);
  const double n = static_cast<double>(frames.size());
  std::printf("ingest_bench: %zu encoded frames, %.1f MB of TFRecords, %d threads, best of %d\n",
              frames.size(), input_mb, threads, repeats);
  std::printf("%-34s %9s %10s %12s\n", "run", "seconds", "MB/s", "frames/s");
  std::printf("%-34s %9.3f %10.1f %12.0f\n", "bound: OpenCV decode of all frames", decode,
              input_mb / decode, n / decode);
  std::printf("%-34s %9.3f %10.1f %12.0f\n", "wm-ingest (decode-check every frame)", full,
              input_mb / full, n / full);
  std::printf("%-34s %9.3f %10.1f %12.0f\n", "wm-ingest --header-check-only", pass, input_mb / pass,
              n / pass);
  std::printf("ratio full ingest / decode bound: %.2f (goal >= 0.80)\n", decode / full);
  std::printf("pass-through speed-up over full: %.1fx\n", full / pass);
  return 0;
}

// What reading HDF5 demos in a child process costs (Hdf5Isolation, docs/testing.md): every demo
// of one file loaded by Hdf5Source with isolation on and off, same thread, same run; prints the
// times and their ratio, best of --repeats.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>

#include "core/log.h"
#include "ingest/hdf5/hdf5_source.h"

namespace {
using Clock = std::chrono::steady_clock;

// Seconds to load every demo; `frames` gets the number of frames loaded.
double LoadAll(const std::string& input, bool isolated, size_t& frames) {
  wm::ingest::Hdf5Source source(input, "", true, {.enabled = isolated});
  const auto start = Clock::now();
  frames = 0;
  for (const auto& ref : source.ListEpisodes(nullptr)) frames += source.Load(ref).num_steps;
  return std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace

int main(int argc, char** argv) {
  std::string input;
  int repeats = 3;
  CLI::App app{"hdf5_isolation_bench: HDF5 demo loading in a child process vs in-process"};
  app.add_option("--input", input, "robomimic/LIBERO HDF5 file")->required();
  app.add_option("--repeats", repeats)->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  wm::InitLogging("warn");
  double inside = 1e30, isolated = 1e30;
  size_t frames = 0;
  for (int r = 0; r < repeats; ++r) {
    inside = std::min(inside, LoadAll(input, false, frames));
    isolated = std::min(isolated, LoadAll(input, true, frames));
  }
  std::printf("hdf5_isolation_bench: %zu frames (read + PNG-encoded), best of %d, 1 thread\n",
              frames, repeats);
  std::printf("%-28s %9.3f s %10.0f frames/s\n", "in-process reads", inside, frames / inside);
  std::printf("%-28s %9.3f s %10.0f frames/s\n", "child-process reads", isolated,
              frames / isolated);
  std::printf("ratio child-process / in-process time: %.2f\n", isolated / inside);
  return 0;
}

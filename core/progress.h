#pragma once
// Progress for long work: a one-line bar with rate and ETA when stderr is a terminal, plain
// log lines (every 10% or 10 s) when it is not (batch jobs, CI, Slurm logs).
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

namespace wm {

class Progress {
 public:
  // `total` units of `unit` (e.g. "episodes"); total 0 means unknown.
  Progress(std::string label, uint64_t total, std::string unit);
  ~Progress();
  void Add(uint64_t n = 1);  // thread-safe
  void Finish();

  // Formatting pieces, exposed for tests.
  static std::string FormatDuration(double seconds);
  static std::string FormatLine(const std::string& label, uint64_t done, uint64_t total,
                                const std::string& unit, double elapsed_s, int bar_width);

 private:
  void Render(bool final);
  std::string label_, unit_;
  uint64_t total_, done_ = 0;
  bool tty_, finished_ = false;
  std::chrono::steady_clock::time_point start_, last_render_;
  int last_logged_decile_ = -1;
  uint64_t last_logged_done_ = ~uint64_t{0};
  std::mutex mu_;
};

}  // namespace wm

#pragma once
// Where a training step's wall time goes (WM_STEP_TIMES=1 in the environment; docs/gpu.md): the
// trainer marks the end of each phase (batch, forward, backward, ...). On CUDA each mark first
// waits for the device, so asynchronous kernels are charged to the phase that launched them;
// that costs throughput, so the timer is off unless asked for (torch-free interface).
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace wm::trainkit {

class PhaseTimer {
 public:
  // Enabled when WM_STEP_TIMES is set to anything but "" or "0". `cuda`: synchronise at marks.
  explicit PhaseTimer(bool cuda);
  bool enabled() const { return enabled_; }
  void StartStep();
  // Ends the phase that began at the previous mark (or StartStep) and charges it to `phase`.
  void Mark(const std::string& phase);
  // "batch 1.2 ms (3%), forward 20.1 ms (45%), ... over N steps", phases in first-marked order;
  // "" when disabled or before a step.
  std::string Summary() const;

 private:
  bool enabled_, cuda_;
  double last_ = 0;
  int64_t steps_ = 0;
  std::vector<std::pair<std::string, double>> totals_;  // seconds per phase, in mark order
};

}  // namespace wm::trainkit

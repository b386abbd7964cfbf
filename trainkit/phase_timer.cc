#include "trainkit/phase_timer.h"

#include <torch/cuda.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>

namespace wm::trainkit {
namespace {

double Now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

bool RequestedByEnvironment() {
  const char* v = std::getenv("WM_STEP_TIMES");
  return v != nullptr && *v != '\0' && std::string(v) != "0";
}

}  // namespace

PhaseTimer::PhaseTimer(bool cuda) : enabled_(RequestedByEnvironment()), cuda_(cuda) {}

void PhaseTimer::StartStep() {
  if (!enabled_) return;
  if (cuda_) torch::cuda::synchronize();
  last_ = Now();
  ++steps_;
}

void PhaseTimer::Mark(const std::string& phase) {
  if (!enabled_) return;
  if (cuda_) torch::cuda::synchronize();
  const double now = Now();
  auto it = totals_.begin();
  while (it != totals_.end() && it->first != phase) ++it;
  if (it == totals_.end()) it = totals_.insert(it, {phase, 0.0});
  it->second += now - last_;
  last_ = now;
}

std::string PhaseTimer::Summary() const {
  if (!enabled_ || steps_ == 0) return "";
  double total = 0;
  for (const auto& [_, seconds] : totals_) total += seconds;
  std::string out;
  for (const auto& [phase, seconds] : totals_) {
    char part[128];
    std::snprintf(part, sizeof part, "%s%s %.2f ms (%.0f%%)", out.empty() ? "" : ", ",
                  phase.c_str(), 1e3 * seconds / steps_, total > 0 ? 100 * seconds / total : 0.0);
    out += part;
  }
  return out + " per step over " + std::to_string(steps_) + " steps";
}

}  // namespace wm::trainkit

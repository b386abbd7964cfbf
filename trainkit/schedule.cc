#include "trainkit/schedule.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace wm::trainkit {

double LearningRateAt(const LrSchedule& t, int64_t step) {
  if (step < t.warmup_steps) return t.max_lr * static_cast<double>(step + 1) / t.warmup_steps;
  const double span = std::max<int64_t>(1, t.steps - t.warmup_steps);
  const double progress = std::min(1.0, static_cast<double>(step - t.warmup_steps) / span);
  return t.min_lr + 0.5 * (t.max_lr - t.min_lr) * (1.0 + std::cos(std::numbers::pi * progress));
}

}  // namespace wm::trainkit

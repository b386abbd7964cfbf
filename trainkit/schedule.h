#pragma once
// The learning-rate schedule both trainers use (torch-free).
#include <cstdint>

namespace wm::trainkit {

// The train-section fields that shape the schedule (docs/config.md).
struct LrSchedule {
  double max_lr = 3e-4;
  double min_lr = 3e-5;
  int64_t warmup_steps = 100;
  int64_t steps = 2000;  // train.steps: where the cosine reaches min_lr
};

// The schedule fields of a stage's train section (tokenize::TrainConfig, train::TrainConfig).
template <typename TrainSection>
LrSchedule ScheduleOf(const TrainSection& t) {
  return {.max_lr = t.max_lr, .min_lr = t.min_lr, .warmup_steps = t.warmup_steps, .steps = t.steps};
}

// lr at `step` (0-based): linear warmup to max_lr over warmup_steps, then cosine to min_lr at
// `steps`.
double LearningRateAt(const LrSchedule& schedule, int64_t step);

}  // namespace wm::trainkit

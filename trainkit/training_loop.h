#pragma once
// The step loop both trainers run (torch-free): the stage trains one step at a time; the loop
// decides which steps log a metrics.csv row and which end with a checkpoint, keeps the
// throughput column and the progress bar. Rows and checkpoints depend only on the step, so a
// resumed run writes what an uninterrupted one does.
#include <cstdint>
#include <optional>
#include <string>
#include <utility>

#include "trainkit/step_log.h"

namespace wm::trainkit {

struct LoopOptions {
  int64_t start_step = 0;  // the checkpoint's step when resuming, else 0
  int64_t steps = 0;       // train.steps: the schedule's end
  // Stop (with a checkpoint) after this many steps of this invocation, 0 = run to `steps`.
  int64_t max_steps_this_run = 0;
  int64_t log_every = 1, checkpoint_every = 1;  // train.log_every, train.checkpoint_every
  bool writer = true;          // writes rows and checkpoints (data parallel: rank 0 only)
  std::string progress_label;  // empty = no progress bar
};

// The options of a run from `start_step` under a stage's train section (steps, log_every,
// checkpoint_every); `progress_label` empty = no progress bar.
template <class TrainSection>
LoopOptions LoopOptionsOf(const TrainSection& t, int64_t start_step, int64_t max_steps_this_run,
                          std::string progress_label) {
  return {.start_step = start_step,
          .steps = t.steps,
          .max_steps_this_run = max_steps_this_run,
          .log_every = t.log_every,
          .checkpoint_every = t.checkpoint_every,
          .progress_label = std::move(progress_label)};
}

// Whether a stage validates after `step` (steps done): every `val_every` steps (0 = never
// before the end) and always at the schedule's end `steps`.
inline bool IsValidationStep(int64_t step, int64_t steps, int64_t val_every) {
  return step == steps || (val_every > 0 && step % val_every == 0);
}

// Where a finished step stands.
struct StepInfo {
  int64_t step = 0;      // steps done, this one included
  bool first = false;    // the first step of this invocation
  bool log_row = false;  // metrics.csv gets a row: step % log_every == 0 or the schedule's end
  bool last = false;     // the last step of this invocation
};

// A metrics.csv row around the loop's throughput column: "step,<before>,<throughput><after>".
struct MetricsRow {
  std::string before;
  std::string after;
};

class TrainingStage {
 public:
  virtual ~TrainingStage() = default;
  // Trains step `step` (0-based) of an invocation that stops before step `stop`.
  virtual void Train(int64_t step, int64_t stop) = 0;
  // Work units (frames, tokens) one step trains, for the throughput column.
  virtual int64_t UnitsPerStep() const = 0;
  // After each step, on every process: validation, statistics; the row when `info.log_row`.
  virtual std::optional<MetricsRow> Finish(const StepInfo& info) = 0;
  // Writes the checkpoint at `step` (writer only).
  virtual void SaveCheckpoint(int64_t step) = 0;
};

// Runs steps start_step .. stop-1 and returns stop (start_step when there is nothing left).
// `metrics` (may be null on non-writing processes) gets the rows.
int64_t RunTrainingLoop(const LoopOptions& options, TrainingStage& stage, StepLog* metrics);

}  // namespace wm::trainkit

#pragma once
// CSV logs keyed by training step (a run's metrics.csv, val.csv): the first column is the step.
// Rows depend only on the step, so a resumed run's log has the rows of an uninterrupted one.
// Each log is mirrored into a TensorBoard event file beside it (docs/tensorboard.md).
#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "core/tensorboard_events.h"

namespace wm::trainkit {

// Rewrites `path` (atomically) with `header` and only the rows whose step is <= `step`, so a run
// resumed from the checkpoint at `step` continues its log without the rows of the lost steps.
// A missing file becomes just the header.
void TruncateStepLog(const std::string& path, const std::string& header, int64_t step);

// The TensorBoard event file mirroring the step log at `csv_path`: "DIR/metrics.csv" ->
// "DIR/events.out.tfevents.metrics". A fixed name (not TensorBoard's timestamp.host) so that a
// resumed run rewrites the same file instead of leaving a second one.
std::string EventFileFor(const std::string& csv_path);

// Appends rows to a step log that TruncateStepLog has cut back to the resume step, and each row
// as one scalar event (tag "<csv stem>/<column>", empty cells left out) to EventFileFor(path),
// which the constructor rewrites from the rows kept (their wall_time is then the resume time).
class StepLog {
 public:
  StepLog(std::string path, const std::string& header, int64_t resume_step);
  // `row` without its newline; flushed at once so a kill loses no written row. Throws wm::Error
  // naming the file when the row cannot be written (disk full).
  void Append(const std::string& row);

 private:
  std::string EventFor(const std::string& row) const;

  std::string path_;
  std::string events_path_;
  std::vector<std::string> tags_;  // per column after the step
};

// Images for TensorBoard (a tokenizer's reconstructions at each validation step) in their own
// event file, "DIR/events.out.tfevents.<name>": they have no CSV to be rebuilt from, so on
// resume the constructor keeps the file's events up to `resume_step` (and drops a record cut by
// a kill) instead of rewriting it from a log.
class ImageLog {
 public:
  ImageLog(const std::string& dir, const std::string& name, int64_t resume_step);
  void Append(int64_t step, const ImageSummary& image);  // flushed at once, like StepLog
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// Work units (frames, tokens) per wall-clock second since the last row: the throughput column.
// It is the only column of metrics.csv that differs between identical runs.
class ThroughputWindow {
 public:
  void Add(int64_t units) { units_ += units; }
  double TakeRate();  // units / seconds since the last TakeRate (or construction); restarts

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  int64_t units_ = 0;
};

}  // namespace wm::trainkit

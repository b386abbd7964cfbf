#include "trainkit/training_loop.h"

#include <algorithm>
#include <sstream>

#include "core/progress.h"

namespace wm::trainkit {

int64_t RunTrainingLoop(const LoopOptions& o, TrainingStage& stage, StepLog* metrics) {
  int64_t stop = o.steps;
  if (o.max_steps_this_run > 0) stop = std::min(stop, o.start_step + o.max_steps_this_run);
  std::optional<Progress> progress;
  if (!o.progress_label.empty() && o.writer) {
    progress.emplace(o.progress_label, stop - o.start_step, "steps");
  }
  ThroughputWindow window;
  for (int64_t step = o.start_step; step < stop;) {
    stage.Train(step, stop);
    ++step;
    window.Add(stage.UnitsPerStep());
    const StepInfo info{.step = step,
                        .first = step == o.start_step + 1,
                        .log_row = step % o.log_every == 0 || step == o.steps,
                        .last = step == stop};
    const std::optional<MetricsRow> row = stage.Finish(info);
    if (row && info.log_row && metrics != nullptr) {
      std::ostringstream line;
      line << step << ',' << row->before << ',' << window.TakeRate() << row->after;
      metrics->Append(line.str());
    }
    if (o.writer && (step % o.checkpoint_every == 0 || step == stop)) stage.SaveCheckpoint(step);
    if (progress) progress->Add(1);
  }
  if (progress) progress->Finish();
  return std::max(stop, o.start_step);
}

}  // namespace wm::trainkit

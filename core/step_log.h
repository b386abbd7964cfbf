#pragma once
// CSV logs keyed by training step (a run's metrics.csv, val.csv): the first column is the step.
#include <cstdint>
#include <string>

namespace wm {

// Rewrites `path` (atomically) with `header` and only the rows whose step is <= `step`, so a run
// resumed from the checkpoint at `step` continues its log without the rows of the lost steps.
// A missing file becomes just the header.
void TruncateStepLog(const std::string& path, const std::string& header, int64_t step);

}  // namespace wm

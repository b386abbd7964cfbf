#pragma once
// TensorBoard event records, hand-encoded: the few protobuf fields of tensorflow.Event and
// tensorflow.Summary that scalars need, so the trainers write event files without protobuf (the
// model-only build has none). Field numbers from tensorflow/core/util/event.proto and
// tensorflow/core/framework/summary.proto; layout and use in docs/tensorboard.md.
#include <cstdint>
#include <string>
#include <vector>

namespace wm {

// What TensorBoard expects as the first event's file_version.
inline constexpr const char* kEventFileVersion = "brain.Event:2";

struct ScalarSummary {
  std::string tag;  // "metrics/loss": TensorBoard groups charts by the part before '/'
  float value = 0;
};

// Event{wall_time = 1 (double), file_version = 3 (string)}: the first record of every file.
std::string EncodeFileVersionEvent(double wall_time);
// Event{wall_time = 1, step = 2 (int64), summary = 5 {value = 1 (repeated)
// {tag = 1 (string), simple_value = 2 (float)}}}.
std::string EncodeScalarsEvent(double wall_time, int64_t step,
                               const std::vector<ScalarSummary>& values);

// Seconds since the Unix epoch, the event's wall_time.
double EventWallTime();

}  // namespace wm

#pragma once
// TensorBoard event records, hand-encoded: the few protobuf fields of tensorflow.Event and
// tensorflow.Summary that scalars and PNG images need, so the trainers write event files without
// protobuf (the model-only build has none). Field numbers from tensorflow/core/util/event.proto and
// tensorflow/core/framework/summary.proto; layout and use in docs/tensorboard.md.
#include <cstdint>
#include <string>
#include <string_view>
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

// An image summary: a PNG and what TensorBoard shows of it.
struct ImageSummary {
  std::string tag;  // "val/reconstructions"
  int height = 0, width = 0;
  int channels = 3;  // Summary.Image colorspace: 1 grey, 3 RGB
  std::string png;   // the encoded image
};

// Event{wall_time = 1, step = 2, summary = 5 {value = 1 {tag = 1, image = 4 {height = 1,
// width = 2, colorspace = 3 (int32 varints), encoded_image_string = 4 (bytes)}}}}.
std::string EncodeImageEvent(double wall_time, int64_t step, const ImageSummary& image);

// The step (field 2) of an encoded Event; 0 when it has none, as protobuf's default (the
// file_version event). Throws wm::Error on bytes that are not a protobuf message.
int64_t DecodeEventStep(std::string_view event);

// Seconds since the Unix epoch, the event's wall_time.
double EventWallTime();

}  // namespace wm

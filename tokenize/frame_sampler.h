#pragma once
// Training frames from one or more shard datasets. A frame is drawn by picking a dataset with
// probability proportional to its weight (a mixture file, else its step count), then an
// episode uniformly, then a step uniformly. The draw for (batch step, slot) is a pure function
// of (seed, step, slot) through a SplitMix64 hash, so batches can be prepared ahead on another
// thread, and a resumed run draws the same frames, without any RNG state to carry.
// Only the sampled frames are decoded, so memory is bounded by the batch.
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "trainkit/frame_decode.h"

namespace wm::shard {
class DatasetReader;
}

namespace wm::tokenize {

// Frame decoding is shared with the motion trainer (trainkit/frame_decode.h).
using trainkit::DecodeFrame;
using trainkit::Rgb8ToPlanar;

struct FrameRef {
  size_t dataset = 0, episode = 0, step = 0;
};

// The anchor of a frame for an anchored tokenizer (model.anchor_decoder): an earlier frame of
// the same episode, or none (blank: decoded from the tokens alone).
struct AnchorRef {
  FrameRef frame;
  bool blank = true;
};

// Each frame's anchor `gap` steps earlier (clamped to the episode's first frame); frames at step
// 0 have none. Validation's fixed rule.
std::vector<AnchorRef> FixedGapAnchors(const std::vector<FrameRef>& frames, int gap);

class FrameSampler {
 public:
  // `weights`: one per dataset (any positive scale), empty = proportional to num_steps.
  FrameSampler(const std::vector<std::string>& dataset_dirs, std::string image_key, int size,
               uint64_t seed, std::vector<double> weights = {});
  ~FrameSampler();

  // The frames of training batch `step` (slots 0..batch_size-1).
  std::vector<FrameRef> BatchRefs(int64_t step, int batch_size) const;
  // Every frame, in order, of up to `max_episodes` episodes taken from the datasets in order
  // (dataset 0's first episodes first): whole clips, for metrics over consecutive frames.
  std::vector<std::vector<FrameRef>> EpisodeRefs(size_t max_episodes) const;
  // The anchors of BatchRefs(step, ...) = `frames`: gap k uniform in [1, min(t, max_gap)], blank
  // with probability `dropout` and at t = 0. Like BatchRefs, a pure function of (seed, step, slot).
  std::vector<AnchorRef> TrainingAnchors(const std::vector<FrameRef>& frames, int64_t step,
                                         int max_gap, double dropout) const;
  // Decodes `refs` into out[refs.size() * 3 * size * size] ([B, 3, H, W]); reads each episode
  // once. Const and thread-safe: the readers are read-only memory maps.
  void Load(const std::vector<FrameRef>& refs, float* out) const;
  // The same for anchors; a blank anchor is all zeros (mid-grey), the model's "no anchor".
  void Load(const std::vector<AnchorRef>& anchors, float* out) const;
  // Load(refs, frames_out) and Load(anchors, anchors_out) in one pass: an anchor comes from its
  // frame's episode, so each episode is read and checked once, and blank anchors are not decoded.
  void Load(const std::vector<FrameRef>& refs, const std::vector<AnchorRef>& anchors,
            float* frames_out, float* anchors_out) const;

  std::vector<std::string> dataset_names() const;
  std::vector<double> step_counts() const;

  // Per dataset: {"dataset", "split", "weight", "index_config_hash", "num_steps", "shards":
  // [{"file", "sha256"}]} for manifests; no paths, so manifests do not depend on where data
  // lives.
  nlohmann::json DataProvenance() const;

 private:
  // Decodes each frame into its destination (3 * size * size floats), reading each episode once.
  void LoadInto(const std::vector<std::pair<FrameRef, float*>>& slots) const;

  std::vector<std::unique_ptr<shard::DatasetReader>> readers_;
  std::vector<double> weights_prefix_;  // cumulative normalised weights, last = 1
  std::string image_key_;
  int size_;
  uint64_t seed_;
};

}  // namespace wm::tokenize

#pragma once
// Training windows of the motion model from a shard dataset: frames t-1, t, ..., t+U of one
// episode (frame t-1 is frame t at an episode's first step) and the actions a_t..a_{t+U-1}
// that lead from each to the next. A window starts at any (episode, t) with t + U < T, all
// equally likely. The windows of a batch are a pure function of (seed, step), drawn from a
// std::mt19937_64 seeded with MixBits(seed, step) through its raw outputs, so a resumed run
// draws exactly the windows of an uninterrupted one. Only the sampled frames are decoded.
// Torch-free.
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "trainkit/action_norm.h"

namespace wm::shard {
class DatasetReader;
}

namespace wm::motion {

struct WindowRef {
  int64_t episode = 0, start = 0;  // frame t of the window is `start`
};

// Two frames of one episode (the pose kind's autoencoder: a frame, and the one its background is
// made from).
struct PairRef {
  int64_t episode = 0, frame = 0, source = 0;
};

// Whole episodes in host memory, for validation rollouts.
struct EpisodeClip {
  int64_t frames = 0;
  std::vector<float> pixels;   // [frames, 3, S, S] in [-1, 1]
  std::vector<float> actions;  // [frames, D] raw
};

class WindowSampler {
 public:
  // Throws wm::Error naming `dir` when no episode has more than `unroll` steps.
  WindowSampler(const std::string& dir, std::string image_key, int size, int unroll);
  ~WindowSampler();

  std::vector<WindowRef> Draw(uint64_t seed, int64_t step, int batch) const;
  // frames [B, U + 2, 3, S, S] (t-1, t, ..., t+U); actions [B, U, D] normalised.
  void Load(const std::vector<WindowRef>& refs, float* frames, float* actions) const;
  // Pairs of frames: each pair's episode uniform over those with more than `unroll` steps, then
  // its frame uniform over the episode's and its source uniform over those at most `window`
  // steps from it (0: over the whole episode, independently); a pure function of (seed, step).
  std::vector<PairRef> DrawPairs(uint64_t seed, int64_t step, int batch, int window = 0) const;
  // frames and sources [B, 3, S, S].
  void LoadPairs(const std::vector<PairRef>& refs, float* frames, float* sources) const;
  // The episodes windows are drawn from (more than `unroll` steps), as dataset episode numbers.
  const std::vector<int64_t>& episodes() const { return episodes_; }
  // Dataset episode `episode`, up to `max_frames` frames.
  EpisodeClip Clip(int64_t episode, int64_t max_frames) const;
  // The first `count` episodes (fewer when the dataset has fewer), up to `max_frames` frames.
  std::vector<EpisodeClip> Episodes(int count, int64_t max_frames) const;

  int64_t action_dim() const { return norm_.dim(); }
  const trainkit::ActionNorm& action_norm() const { return norm_; }
  const std::string& action_space() const { return action_space_; }
  std::string dataset_name() const;
  // {"dataset", "split", "index_config_hash", "num_episodes", "num_steps", "shards": [{"file",
  // "sha256"}]}; no paths, so manifests do not depend on where data lives.
  nlohmann::json DataProvenance() const;

 private:
  std::unique_ptr<shard::DatasetReader> reader_;
  std::string image_key_, action_space_;
  int size_, unroll_;
  trainkit::ActionNorm norm_;
  std::vector<int64_t> episodes_;        // episodes with more than `unroll` steps
  std::vector<uint64_t> window_prefix_;  // cumulative window counts over `episodes_`
};

}  // namespace wm::motion

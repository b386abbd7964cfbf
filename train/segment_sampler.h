#pragma once
// Training segments from one or more token datasets (core/tokens/token_dataset.h). A segment is
// `context_frames` consecutive frames of one episode. Sampling is counter-based: the segments of
// a global batch are a pure function of (seed, step), drawn with a std::mt19937_64 seeded from
// SplitMix64(seed, step) through its raw outputs, so a resumed run, or each data-parallel rank
// reading only its slice, sees exactly the segments of an uninterrupted single-process run.
// A dataset is picked with probability proportional to its mixture weight
// (configs/mixtures/*.yaml) or, without a mixture, to its number of segments; then a segment
// uniformly within it. Only the chosen frames are copied (the parts are memory-mapped), so
// memory is bounded by the batch. Torch-free.
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "trainkit/action_norm.h"

namespace wm::tokens {
class TokenDataset;
}

namespace wm::train {

using trainkit::ActionNorm;  // per-dataset action normalisation

struct SegmentRef {
  int dataset = 0;
  int64_t episode = 0, start = 0;
};

// A batch of segments in host memory, row-major.
struct SegmentData {
  int64_t batch = 0;
  std::vector<int64_t> tokens;  // [B, T, N]
  std::vector<float> actions;   // [B, T, D] normalised, zero-padded to the sampler's D
  // [B, D] 1/0: which values of a row are real (not padding); empty when every dataset has D.
  std::vector<float> action_mask;
  std::vector<float> rewards;    // [B, T]
  std::vector<float> terminals;  // [B, T] 0/1
};

class SegmentSampler {
 public:
  // `mixture_file`: configs/mixtures/*.yaml (trainkit/mixture.h), empty = weight by size.
  // Throws wm::Error when a dataset has no episode of at least `context_frames` frames, when
  // datasets disagree on the tokenizer, or when the mixture misses a dataset. `action_dim`: the
  // width D segments are padded to (0 = the widest dataset's; a wider dataset is an error).
  SegmentSampler(const std::vector<std::string>& dirs, int context_frames,
                 const std::string& mixture_file = "", int64_t action_dim = 0);
  ~SegmentSampler();

  // The `batch` segments of global step `step`.
  std::vector<SegmentRef> Draw(uint64_t seed, int64_t step, int batch) const;
  // Copies refs[first, first + count) into `out`.
  void Fill(const std::vector<SegmentRef>& refs, size_t first, size_t count,
            SegmentData& out) const;

  int64_t tokens_per_frame() const;
  int64_t num_codes() const;
  int grid_h() const;
  int grid_w() const;
  int levels() const;          // codes per cell (tokenizer.levels)
  int64_t action_dim() const;  // D of every segment's actions
  // By dataset name, for checkpoints (the public model API normalises raw actions with these).
  nlohmann::json ActionNorms() const;
  // Per dataset: {"dataset", "split", "index_sha256", "tokenizer_checkpoint_sha256",
  // "tokenizer_config_hash", "num_episodes", "num_frames", "weight"}; no paths.
  nlohmann::json DataProvenance() const;

 private:
  struct Source;
  std::vector<std::unique_ptr<Source>> sources_;
  std::vector<double> cumulative_weight_;  // normalised, last = 1
  int context_frames_;
  void SetActionWidth(int64_t requested);  // action_dim_ and mixed_widths_ from the sources
  int64_t action_dim_ = 0;
  bool mixed_widths_ = false;  // some dataset is narrower than action_dim_: Fill writes the mask
};

// SplitMix64 of (seed, counter): the seed of every counter-based generator here.
uint64_t MixSeed(uint64_t seed, uint64_t counter);

}  // namespace wm::train

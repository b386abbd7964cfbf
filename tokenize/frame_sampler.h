#pragma once
// Random training frames from one or more shard datasets. A frame is drawn by picking a
// dataset with probability proportional to its step count, then an episode uniformly, then a
// step uniformly; only the sampled frames are decoded, so memory is bounded by the batch.
// Randomness is one std::mt19937_64 used through its raw outputs (`x % n`, whose bias is below
// n / 2^64) because std::uniform_int_distribution differs between standard libraries.
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

namespace wm::shard {
class DatasetReader;
}

namespace wm::tokenize {

// Decodes an encoded JPEG/PNG frame, converts BGR->RGB, resizes (INTER_AREA) to size x size
// and writes planar floats in [-1, 1] to out[3 * size * size] ([3, H, W]).
void DecodeFrame(const std::string& encoded, int size, float* out);

class FrameSampler {
 public:
  FrameSampler(const std::vector<std::string>& dataset_dirs, std::string image_key, int size,
               uint64_t seed);
  ~FrameSampler();

  // Fills batch[B * 3 * size * size] ([B, 3, H, W]) with B freshly sampled frames.
  void NextBatch(int batch_size, std::vector<float>& batch);

  // The RNG state as text (operator<< of std::mt19937_64), for checkpoints and resume.
  std::string rng_state() const;
  void set_rng_state(const std::string& state);

  // Per dataset: {"dataset", "split", "index_config_hash", "num_steps", "shards": [{"file",
  // "sha256"}]} for manifests; no paths, so manifests do not depend on where data lives.
  nlohmann::json DataProvenance() const;

 private:
  std::vector<std::unique_ptr<shard::DatasetReader>> readers_;
  std::vector<uint64_t> steps_prefix_;  // cumulative num_steps over datasets
  std::string image_key_;
  int size_;
  std::mt19937_64 rng_;
};

}  // namespace wm::tokenize

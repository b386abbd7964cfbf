#pragma once
// Small helpers shared by the C++ tests: temp directories and a synthetic episode.
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "core/episode.h"
#include "core/tokens/token_dataset.h"

namespace wm::shard {
class DatasetWriter;
}

namespace wm::test {

// A fresh directory under the system temp dir, removed when the object dies.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  const std::filesystem::path& path() const { return path_; }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

// A deterministic episode with `steps` steps, actions from `seed`, fake JPEG-magic frames.
Episode MakeEpisode(int steps, uint64_t seed, const std::string& key = "ep");

// `episode`'s "image" stream replaced by `frames`: encoded size x size RGB PNGs, one per step
// (the fixtures' own drawings).
void SetPngFrames(Episode& episode, std::vector<std::string> frames, int size);

// Finishes `writer`'s dataset as the "train" split of dataset `name`.
void FinishTrainSplit(shard::DatasetWriter& writer, const std::string& name);

// A token dataset in `dir`: `episodes` MakeEpisode episodes of 3..6 steps split over
// `num_parts` parts, tokens drawn from `seed` on a grid_h x grid_w grid of `num_codes` codes.
// Returns the tokens written, per episode ([frames * levels * grid_h * grid_w]). An `action_dim`
// other than 7 writes "joint_position" actions of that width (action value i of episode k:
// k + i/100); `levels` > 1 writes a residual tokenizer's level stacks (format_version 3).
std::vector<std::vector<uint32_t>> MakeTokenDataset(const std::string& dir, int episodes,
                                                    int num_parts, int grid_h, int grid_w,
                                                    int64_t num_codes, uint64_t seed,
                                                    int64_t action_dim = kActionDim,
                                                    int levels = 1);

// The repository root and the directory of built tools ($WM_SOURCE_DIR / $WM_BIN_DIR, else the
// paths compiled into the test).
std::string SourceDir();
std::string BinDir();
// The shared real-data samples: $WM_SHARED_DIR/samples, else <source>/../shared/samples.
std::string SamplesDir();

// The message of the wm::Error that f() throws, or "(no error)".
std::string ErrorText(const std::function<void()>& f);

// Two tensor archives compared by tensor-name prefix (the fine-tuning tests): the names under
// `prefix` in `archive`; those whose bytes differ in `b` (or that `b` lacks); and the largest
// |a - b| over the float32 ones.
std::vector<std::string> TensorNames(const std::string& archive, const std::string& prefix);
std::vector<std::string> ChangedTensors(const std::string& a, const std::string& b,
                                        const std::string& prefix);
double MaxFloat32Difference(const std::string& a, const std::string& b, const std::string& prefix);

void FlipByte(const std::string& file, uint64_t offset);
void Truncate(const std::string& file, uint64_t new_size);

}  // namespace wm::test

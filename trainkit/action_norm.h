#pragma once
// Per-dataset action normalisation (a - mean) / std with a dataset's index statistics, stored in
// checkpoints by dataset name so the public model APIs normalise raw actions as training did.
// Shared by the token dynamics model (train/) and the motion model (motion/). Torch-free.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <vector>

namespace wm::trainkit {

// std < 1e-6 is treated as 1 (a constant action dimension).
struct ActionNorm {
  std::vector<double> mean, std;  // D each: the dataset's action width
  int64_t dim() const { return static_cast<int64_t>(mean.size()); }
  // raw [steps, D] -> out rows of `out_stride` >= D values (the first D written; 0 = D).
  void Apply(const float* raw, float* out, int64_t steps, int64_t out_stride = 0) const;
  nlohmann::json ToJson() const;
  static ActionNorm FromJson(const nlohmann::json& j);
};

}  // namespace wm::trainkit

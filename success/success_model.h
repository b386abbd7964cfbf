#pragma once
// Public, torch-free API of a trained success classifier (wm-success train): load a checkpoint
// and score frames, real or imagined, with P(success | frame) (docs/success.md).
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "success/config.h"

namespace wm::success {

class SuccessModel {
 public:
  // `path`: a RUN_DIR or its checkpoint.wmt. `device`: "cpu", "cuda" or "cuda:N". `threads`
  // sets LibTorch's intra-op threads (0 = leave).
  static std::unique_ptr<SuccessModel> Load(const std::string& path,
                                            const std::string& device = "cpu", int threads = 0);
  ~SuccessModel();

  // Whether `path` (a RUN_DIR or checkpoint.wmt) holds a success classifier (meta "model_kind").
  static bool IsSuccessCheckpoint(const std::string& path);

  const SuccessConfig& config() const;
  int64_t image_size() const;
  int64_t step() const;  // training step of the checkpoint
  const std::string& checkpoint_file() const;

  // `frames`: [count, 3, S, S] planar RGB in [-1, 1] (trainkit::DecodeFrame's layout). Returns
  // P(success) per frame [count]. Deterministic on CPU; a frame's value depends on it alone.
  std::vector<float> Probabilities(const std::vector<float>& frames, int64_t count) const;

 private:
  SuccessModel();
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace wm::success

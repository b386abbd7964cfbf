#pragma once
// Public, torch-free API of a trained motion model (wm-motion train), for evaluation and tools:
// load a checkpoint and imagine frames from a real first frame under raw actions.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "motion/config.h"

namespace wm::motion {

class MotionModel {
 public:
  // `path`: a RUN_DIR or its checkpoint.wmt. `device`: "cpu", "cuda" or "cuda:N". `threads`
  // sets LibTorch's intra-op threads (0 = leave).
  static std::unique_ptr<MotionModel> Load(const std::string& path,
                                           const std::string& device = "cpu", int threads = 0);
  ~MotionModel();

  // Whether `path` (a RUN_DIR or checkpoint.wmt) holds a motion model (meta "model_kind").
  static bool IsMotionCheckpoint(const std::string& path);

  const MotionConfig& config() const;
  int64_t image_size() const;
  int64_t action_dim() const;  // values per raw action
  int64_t step() const;        // training step of the checkpoint
  const std::string& checkpoint_file() const;

  // `first`: [batch, 3, S, S] planar RGB in [-1, 1] (trainkit::DecodeFrame's layout);
  // `raw_actions`: [batch, horizon, action_dim()] as logged (normalised inside with the training
  // data's statistics). Returns the imagined frames [batch, horizon, 3, S, S] in [-1, 1].
  // Deterministic on CPU; a row depends only on its own inputs.
  std::vector<float> Imagine(const std::vector<float>& first, const std::vector<float>& raw_actions,
                             int64_t batch, int64_t horizon) const;

  // One step of Imagine, for a caller that picks each action after seeing the last frame (a
  // policy in closed loop): the frame after `current`, `previous` being the frame before it
  // (`current` again at an episode's first frame), under `raw_actions` [batch, action_dim()].
  // Frames as for Imagine; returns [batch, 3, S, S] in [-1, 1], clamped. Chained, these are
  // Imagine's frames.
  std::vector<float> ImagineNext(const std::vector<float>& current,
                                 const std::vector<float>& previous,
                                 const std::vector<float>& raw_actions, int64_t batch) const;

 private:
  MotionModel();
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace wm::motion

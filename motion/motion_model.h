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

  // Imagine one step at a time, for a caller that picks each action after seeing the last frame
  // (a policy in closed loop): a rollout from `first` (as for Imagine) whose Next(raw_actions
  // [batch, action_dim()]) returns the next frames [batch, 3, S, S] in [-1, 1]. Its frames are
  // Imagine's. The model must outlive it.
  class Rollout {
   public:
    ~Rollout();
    std::vector<float> Next(const std::vector<float>& raw_actions);

   private:
    friend class MotionModel;
    struct State;
    explicit Rollout(std::unique_ptr<State> state);
    std::unique_ptr<State> state_;
  };
  std::unique_ptr<Rollout> StartRollout(const std::vector<float>& first, int64_t batch) const;

 private:
  MotionModel();
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace wm::motion

#pragma once
// Public, torch-free API of a trained dynamics model, for evaluation (wm-eval) and tools:
// load a wm-train checkpoint, predict the next frame's tokens from context frames and actions
// (MaskGIT decoding), predict per-step rewards and terminal probabilities, and read the policy
// embedding the prior infers from a context. All arrays are row-major std::vectors.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "train/config.h"

namespace wm::train {

// A batch of context windows: `frames` consecutive token frames per row and the action taken
// at each (actions[b, t] leads from frame t to frame t+1).
struct FrameContext {
  int64_t batch = 1, frames = 0;
  std::vector<int64_t> tokens;  // [batch, frames, tokens_per_frame()] codes in [0, num_codes)
  std::vector<float> actions;   // [batch, frames, action_dim()] raw actions (normalised inside)
  // Optional [batch, categories * classes] class probabilities (or one-hots) used as z for
  // every step instead of the prior's inference; empty = the prior p(z | tau_h) (WHALE eq. 5).
  std::vector<float> policy_z;
  // Optional [batch] MaskGIT sampling seeds, one per row; empty = MixSeed(seed, row).
  std::vector<uint64_t> row_seeds;
};

// Per frame t, the reward and terminal flag RLDS logs with observation t (step t).
struct RewardPrediction {
  std::vector<float> reward;         // [batch, frames]: r_t
  std::vector<float> terminal_prob;  // [batch, frames]: P(is_terminal_t)
};

// One imagined step per row (DynamicsModel::ImagineStep).
struct ImaginedSteps {
  std::vector<int64_t> tokens;       // [batch, N]: the next frame
  std::vector<float> reward;         // [batch]: r_t of the step to it
  std::vector<float> terminal_prob;  // [batch]: P(is_terminal_t)
};

class RollingImagination;

class DynamicsModel {
 public:
  // `path`: a RUN_DIR or its checkpoint.wmt. `device`: "cpu", "cuda" or "cuda:N".
  // `action_dataset`: whose action statistics normalise raw actions (a dataset the model was
  // trained on; empty = the first). `threads` sets LibTorch's intra-op threads (0 = leave).
  static std::unique_ptr<DynamicsModel> Load(const std::string& path,
                                             const std::string& device = "cpu",
                                             const std::string& action_dataset = "",
                                             int threads = 0);
  ~DynamicsModel();

  // Whether the checkpoint at `path` was trained on `dataset` (has its action statistics).
  static bool HasActionDataset(const std::string& path, const std::string& dataset);

  const DynamicsConfig& config() const;
  int64_t tokens_per_frame() const;
  // Values per raw action FrameContext::actions holds: the action dataset's width. It is the
  // model's config().model.action_dim, or less for a narrower dataset of a mixture (zero-padded
  // and masked inside, as in training). Another width is an error naming both.
  int64_t action_dim() const;
  int64_t step() const;                        // training step of the checkpoint
  const std::string& checkpoint_file() const;  // the checkpoint.wmt that was loaded
  // Longest context PredictNextFrame takes (context_frames - 1); longer contexts keep their
  // last frames (a sliding window).
  int64_t max_context_frames() const;
  // The temperature PredictNextFrame decodes with when asked for `requested`: the config's
  // model.decode_temperature when `requested` < 0 (0 = argmax).
  double DecodeTemperature(double requested) const;

  // Tokens of frame `frames` [batch, N]. `steps` / `temperature` <= 0 / < 0 take the config's
  // model.decode_steps / model.decode_temperature. Deterministic for a given seed on CPU; a row's
  // frame depends only on its own context and seed, not on the other rows.
  // `token_entropy`, when given, receives [batch, N]: the entropy (nats) of the model's
  // (untempered) distribution of each token in the MaskGIT round that fixed it, or of the one
  // pass of a next_frame model; asking for it does not change the frame.
  std::vector<int64_t> PredictNextFrame(const FrameContext& context, uint64_t seed = 0,
                                        int steps = 0, double temperature = -1,
                                        std::vector<float>* token_entropy = nullptr) const;
  // PredictNextFrame, then PredictRewards' last frame for the context extended by the new frame
  // (and an unused zero action), with the window encoded once and reused by every MaskGIT round
  // and the reward (train/imagine_step.h): what the two calls give, up to float rounding.
  // context.frames <= max_context_frames().
  ImaginedSteps ImagineStep(const FrameContext& context, uint64_t seed = 0, int steps = 0,
                            double temperature = -1) const;
  // Whether StartRolling works: a next_frame model with rotary time (model.temporal_positions).
  bool CanRoll() const;
  // Imagination of `batch` episodes in lockstep from their real first frames `first_frames`
  // [batch, N], keeping each frame's temporal keys/values as the window slides
  // (train/rolling_imagination.h: 2 frame passes per imagined frame instead of context_frames;
  // the same as ImagineStep until the window slides, its own semantics after). It imagines with
  // this model, so it must not outlive it.
  std::unique_ptr<RollingImagination> StartRolling(const std::vector<int64_t>& first_frames,
                                                   int64_t batch) const;
  // Reward and terminal probability of each of the context's frames (step t of frame t).
  RewardPrediction PredictRewards(const FrameContext& context) const;
  // The prior's z_h class probabilities after the last frame [batch, categories * classes];
  // empty without policy conditioning.
  std::vector<float> PolicyEmbedding(const FrameContext& context) const;

 private:
  DynamicsModel();
  friend class RollingImagination;
  struct State;
  std::unique_ptr<State> state_;
};

class RollingImagination {
 public:
  ~RollingImagination();
  // One step of the episodes `rows` (ascending indices into the batch; an episode left out once
  // has ended and may not come back): `actions` [rows, action_dim()] raw, each one's action at its
  // newest frame; `row_seeds` one per row; `temperature` < 0 takes the config's. Returns the new
  // frames [rows, N] with the step's reward and terminal probability.
  ImaginedSteps Step(const std::vector<int64_t>& rows, const std::vector<float>& actions,
                     const std::vector<uint64_t>& row_seeds, double temperature = -1);

 private:
  friend class DynamicsModel;
  RollingImagination();
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace wm::train

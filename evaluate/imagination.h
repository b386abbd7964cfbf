#pragma once
// What wm-eval scores of a checkpoint, whatever kind of world model it holds: per episode the
// imagined clips of each rollout, decoded to frames. A token dynamics model (wm-train) imagines
// tokens with the plain and retracing contexts and a reward head; a motion model (wm-motion,
// docs/motion.md) imagines pixels from the real first frame, plain only, without rewards. Both
// fill the same structs, so scoring, reports and shards are one code path (docs/reports.md).
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "evaluate/evaluator.h"
#include "evaluate/frame_scores.h"
#include "evaluate/manifest.h"

namespace wm {
struct Episode;
}
namespace wm::motion {
class MotionModel;
}

namespace wm::evaluate {

// One rollout of one episode, decoded: frames 1..h of each imagination.
struct ImaginedRollout {
  std::vector<Clip> samples;           // sample 0 first
  std::optional<Clip> perturbed;       // controllability: sample 0 with perturbed actions
  std::optional<double> model_return;  // the reward head's return over the h steps, if it has one
  std::vector<std::vector<double>> contexts;  // contexts.csv rows of sample 0 (token models)
  // --retrace-ks (plain rollout of a token model): retrace_disagreement and token_entropy, per step
  std::map<std::string, std::vector<double>> uncertainty;
};
using ImaginedEpisode = std::map<std::string, ImaginedRollout>;  // rollout name -> rollout

// The episode to imagine: `position` in the list given to CheckpointUnderEval::start, its index
// in the token dataset, the real frame 0 at the tokenizer's size, the shard episode, h steps.
struct EpisodeToImagine {
  size_t position = 0;
  int64_t episode = 0;
  const Clip& given;
  const Episode& shard_episode;
  int64_t steps = 0;
};
using Imagination = std::function<ImaginedEpisode(const EpisodeToImagine&)>;

// A loaded checkpoint: `options` are wm-eval's with the rollouts and samples this kind of model
// is scored with (they go into its manifest and part identity); `start` prepares the imagination
// of the given token-dataset episodes (a token model rolls them all out there).
struct CheckpointUnderEval {
  EvalOptions options;
  CheckpointInfo info;
  std::function<Imagination(const std::vector<int64_t>& episodes)> start;
};

// Checkpoint `c` of `o` (name `name`, for warnings): a motion model when
// MotionModel::IsMotionCheckpoint says so, else a token dynamics model. Throws wm::Error when it
// does not fit the tokenizer or the token data.
CheckpointUnderEval LoadCheckpointUnderEval(const EvalOptions& o, size_t c, const std::string& name,
                                            const tokenize::Tokenizer& tok,
                                            const tokens::TokenDataset& data);

// A motion checkpoint of `o` loaded for `tok` and `data` (its frame size and action width
// checked: wm::Error naming the checkpoint otherwise), and what its report manifests say of it.
struct LoadedMotionModel {
  std::shared_ptr<const motion::MotionModel> model;
  CheckpointInfo info;
};
LoadedMotionModel LoadMotionModelFor(const EvalOptions& o, const std::string& checkpoint,
                                     const tokenize::Tokenizer& tok,
                                     const tokens::TokenDataset& data);

// The motion model's side of LoadCheckpointUnderEval (evaluate/motion_imagination.cc).
CheckpointUnderEval LoadMotionCheckpoint(const EvalOptions& o, const std::string& checkpoint,
                                         const std::string& name, const tokenize::Tokenizer& tok,
                                         const tokens::TokenDataset& data);

// Whether `o` asks for delta_tpsnr: a plain rollout and a perturbation.
bool ScoresControllability(const EvalOptions& o);

}  // namespace wm::evaluate

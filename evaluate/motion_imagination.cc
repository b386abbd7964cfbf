// wm-eval of a motion checkpoint (wm-motion train, docs/motion.md): the model imagines pixels
// from the episode's real first frame under its logged actions, so it is scored beside the token
// checkpoints with the same baselines and metrics. What differs (docs/reports.md, "Motion
// checkpoints"): the plain rollout only (retrace is WHALE's token-context rollout), one
// imagination (the model is deterministic), no reward head (no value rows), no contexts.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <memory>

#include "core/episode.h"
#include "core/error.h"
#include "core/provenance.h"
#include "core/tokens/token_dataset.h"
#include "evaluate/controllability.h"
#include "evaluate/imagination.h"
#include "motion/motion_model.h"
#include "tokenize/tokenizer.h"

namespace wm::evaluate {
namespace {

// Throws wm::Error naming the checkpoint when its frames or actions are not the data's.
void CheckMotionModelFits(const motion::MotionModel& model, const tokenize::Tokenizer& tok,
                          const tokens::TokenDataset& data) {
  const std::string size = std::to_string(model.image_size());
  Check(model.image_size() == tok.image_size(),
        "the motion model imagines " + size + "x" + size + " frames, but --tokenizer scores " +
            std::to_string(tok.image_size()) + "x" + std::to_string(tok.image_size()) +
            " frames (train both at one image_size)",
        {.file = model.checkpoint_file(), .key = "model.image_size"});
  Check(model.action_dim() == data.action_dim(),
        "the motion model takes " + std::to_string(model.action_dim()) + "-dim actions; dataset '" +
            data.index().dataset + "' has " + std::to_string(data.action_dim()) + "-dim ones",
        {.file = model.checkpoint_file(), .key = "action_dim"});
}

// The report options of a motion checkpoint: plain only, one sample; says what it drops.
EvalOptions MotionOptions(const EvalOptions& o, const std::string& name) {
  EvalOptions m = o;
  m.modes = {RolloutMode::kPlain};
  m.rollout.samples = 1;
  if (!o.rollout_auto && o.modes != m.modes) {
    spdlog::warn(
        "{}: retrace is the token model's context rollout (WHALE eq. 6) and does not "
        "apply to a motion model: scoring its plain rollout only",
        name);
  }
  if (o.rollout.samples >= 2) {
    spdlog::warn(
        "{}: --samples {}: a motion model is deterministic, so it imagines once (no "
        "uncertainty rows)",
        name, o.rollout.samples);
  }
  if (!o.retrace_ks.empty()) {
    spdlog::warn(
        "{}: --retrace-ks varies a token model's context window; a motion model has none (no "
        "uncertainty.csv)",
        name);
    m.retrace_ks.clear();
  }
  return m;
}

// Frames 1..h imagined from `given` (frame 0) under `actions` rows 0..h-1 ([>= h, D]).
Clip ImagineClip(const motion::MotionModel& model, const Clip& given, const float* actions,
                 int64_t steps) {
  const std::vector<float> rows(actions, actions + steps * model.action_dim());
  return {steps, given.size, model.Imagine(given.pixels, rows, 1, steps)};
}

}  // namespace

LoadedMotionModel LoadMotionModelFor(const EvalOptions& o, const std::string& checkpoint,
                                     const tokenize::Tokenizer& tok,
                                     const tokens::TokenDataset& data) {
  std::shared_ptr<const motion::MotionModel> model =
      motion::MotionModel::Load(checkpoint, o.device, o.threads);
  CheckMotionModelFits(*model, tok, data);
  const nlohmann::json config = motion::ConfigToJson(model->config());
  CheckpointInfo info{
      .file = model->checkpoint_file(),
      .step = model->step(),
      .extra = {{"model_kind", "motion"}, {"config", config}, {"config_hash", ConfigHash(config)}}};
  return {std::move(model), std::move(info)};
}

CheckpointUnderEval LoadMotionCheckpoint(const EvalOptions& o, const std::string& checkpoint,
                                         const std::string& name, const tokenize::Tokenizer& tok,
                                         const tokens::TokenDataset& data) {
  LoadedMotionModel loaded = LoadMotionModelFor(o, checkpoint, tok, data);
  std::shared_ptr<const motion::MotionModel> model = loaded.model;
  CheckpointUnderEval c{.options = MotionOptions(o, name), .info = std::move(loaded.info)};
  const bool perturb = ScoresControllability(c.options);
  const Perturbation p = o.controllability;
  const uint64_t seed = o.rollout.seed;
  // Each episode on its own (batch 1): a shard job imagines exactly what a single job does.
  c.start = [model, perturb, p, seed](const std::vector<int64_t>&) -> Imagination {
    return [model, perturb, p, seed](const EpisodeToImagine& e) {
      const Episode& ep = e.shard_episode;
      ImaginedRollout plain;
      plain.samples = {ImagineClip(*model, e.given, ep.actions.data(), e.steps)};
      if (perturb) {
        const std::vector<float> wrong =
            PerturbActions(ep.actions.data(), ep.action_dim, ep.num_steps, p, seed, e.episode);
        plain.perturbed = ImagineClip(*model, e.given, wrong.data(), e.steps);
      }
      return ImaginedEpisode{{RolloutName(RolloutMode::kPlain), plain}};
    };
  };
  return c;
}

}  // namespace wm::evaluate

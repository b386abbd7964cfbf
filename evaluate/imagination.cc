#include "evaluate/imagination.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <memory>
#include <optional>

#include "core/error.h"
#include "core/progress.h"
#include "core/tokens/token_dataset.h"
#include "evaluate/clip_decode.h"
#include "evaluate/controllability.h"
#include "evaluate/retrace_uncertainty.h"
#include "motion/motion_model.h"
#include "train/dynamics_model.h"

namespace wm::evaluate {
namespace {

// contexts.csv rows of one rollout's sample 0: step (from 0), slot, frame, then the action.
std::vector<std::vector<double>> ContextRows(const std::vector<std::vector<ContextSlot>>& steps) {
  std::vector<std::vector<double>> rows;
  for (size_t t = 0; t < steps.size(); ++t) {
    for (size_t slot = 0; slot < steps[t].size(); ++slot) {
      const ContextSlot& c = steps[t][slot];
      std::vector<double> row = {static_cast<double>(t), static_cast<double>(slot),
                                 static_cast<double>(c.frame)};
      row.insert(row.end(), c.action.begin(), c.action.end());
      rows.push_back(std::move(row));
    }
  }
  return rows;
}

// Episode `position`'s rollout `r` decoded: every sample, the perturbed one, return, contexts.
ImaginedRollout DecodeRollout(const tokenize::Tokenizer& tok, const EpisodeRollout& r,
                              const EpisodeRollout* perturbed, const EpisodeToImagine& e) {
  ImaginedRollout out;
  for (const auto& s : r.tokens) out.samples.push_back(DecodeClip(tok, s, 1, e.steps, e.given));
  if (perturbed) out.perturbed = DecodeClip(tok, perturbed->tokens[0], 1, e.steps, e.given);
  double model_return = 0;
  for (int64_t s = 0; s < e.steps; ++s) model_return += r.rewards[0][s];
  out.model_return = model_return;
  out.contexts = ContextRows(r.contexts);
  return out;
}

// --retrace-ks' signals of one episode's plain rollout (evaluate/retrace_uncertainty.h).
std::map<std::string, std::vector<double>> UncertaintySignals(const tokenize::Tokenizer& tok,
                                                              const RetraceVariants& v,
                                                              const EpisodeToImagine& e) {
  return {{"retrace_disagreement", VariantDisagreement(tok, v, e.given)},
          {"token_entropy", v.token_entropy}};
}

// A token dynamics model rolls out every episode up front (each mode, and plain with perturbed
// actions for controllability), then decodes one episode at a time.
CheckpointUnderEval LoadDynamicsCheckpoint(const EvalOptions& o, size_t c, const std::string& name,
                                           const tokenize::Tokenizer& tok,
                                           const tokens::TokenDataset& data) {
  std::shared_ptr<const train::DynamicsModel> model = LoadModelFor(o, o.checkpoints[c], data);
  CheckModelFitsTokens(*model, data);  // before its report directory exists
  if (o.rollout.samples >= 2 && model->DecodeTemperature(o.rollout.temperature) == 0) {
    spdlog::warn(
        "{}: --samples {} with argmax decoding (temperature 0) imagines {} identical "
        "rollouts: uncertainty is 0 and uncertainty_error_corr undefined; pass "
        "--temperature > 0 to sample",
        name, o.rollout.samples, o.rollout.samples);
  }
  if (!o.retrace_ks.empty()) {
    Check(std::find(o.modes.begin(), o.modes.end(), RolloutMode::kPlain) != o.modes.end(),
          "--retrace-ks imagines variants of the plain rollout's steps: add it (--rollout plain, "
          "both or auto)",
          {.key = "--retrace-ks"});
    CheckRetraceKs(o.retrace_ks, ContextFrames(*model, o.rollout.context));
    CheckRolloutModeFits(RolloutMode::kRetrace, data);
  }
  auto start = [o, model, &tok, &data, name](const std::vector<int64_t>& episodes) -> Imagination {
    // Rolling out is most of a token model's evaluation (scoring has its own bar, after it).
    const bool perturb = ScoresControllability(o);
    std::optional<Progress> progress;
    if (o.show_progress) {
      progress.emplace("imagine " + name, episodes.size() * (o.modes.size() + (perturb ? 1 : 0)),
                       "rollouts");
    }
    Progress* bar = progress ? &*progress : nullptr;
    std::map<RolloutMode, std::vector<EpisodeRollout>> rollouts;
    for (RolloutMode m : o.modes) {
      rollouts[m] = Rollout(*model, data, episodes, m, o.rollout, nullptr, bar);
    }
    std::vector<EpisodeRollout> perturbed;
    if (perturb) {
      perturbed = PerturbedRollout(*model, data, episodes, o.rollout, o.controllability, bar);
    }
    if (progress) progress->Finish();
    std::vector<RetraceVariants> variants;
    if (!o.retrace_ks.empty()) {
      variants = ImagineRetraceVariants(*model, data, rollouts.at(RolloutMode::kPlain),
                                        o.retrace_ks, o.rollout);
    }
    return [rollouts = std::move(rollouts), perturbed = std::move(perturbed),
            variants = std::move(variants), &tok](const EpisodeToImagine& e) {
      ImaginedEpisode out;
      for (const auto& [mode, r] : rollouts) {
        const bool perturb = mode == RolloutMode::kPlain && !perturbed.empty();
        out[RolloutName(mode)] =
            DecodeRollout(tok, r[e.position], perturb ? &perturbed[e.position] : nullptr, e);
      }
      if (!variants.empty()) {
        out.at("plain").uncertainty = UncertaintySignals(tok, variants[e.position], e);
      }
      return out;
    };
  };
  return {.options = o, .info = DescribeDynamicsCheckpoint(*model), .start = start};
}

}  // namespace

std::unique_ptr<train::DynamicsModel> LoadModelFor(const EvalOptions& o,
                                                   const std::string& checkpoint,
                                                   const tokens::TokenDataset& data) {
  const std::string& dataset = data.index().dataset;
  return train::DynamicsModel::Load(
      checkpoint, o.device,
      train::DynamicsModel::HasActionDataset(checkpoint, dataset) ? dataset : "", o.threads);
}

bool ScoresControllability(const EvalOptions& o) {
  return o.controllability != Perturbation::kOff &&
         std::find(o.modes.begin(), o.modes.end(), RolloutMode::kPlain) != o.modes.end();
}

CheckpointUnderEval LoadCheckpointUnderEval(const EvalOptions& o, size_t c, const std::string& name,
                                            const tokenize::Tokenizer& tok,
                                            const tokens::TokenDataset& data) {
  if (motion::MotionModel::IsMotionCheckpoint(o.checkpoints[c])) {
    return LoadMotionCheckpoint(o, o.checkpoints[c], name, tok, data);
  }
  return LoadDynamicsCheckpoint(o, c, name, tok, data);
}

}  // namespace wm::evaluate

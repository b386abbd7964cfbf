#include "evaluate/controllability.h"

#include <algorithm>
#include <random>

#include "core/error.h"
#include "core/tokens/token_dataset.h"

namespace wm::evaluate {

const char* PerturbationName(Perturbation p) {
  switch (p) {
    case Perturbation::kOff:
      return "off";
    case Perturbation::kReversed:
      return "reversed";
    case Perturbation::kShuffled:
      return "shuffled";
  }
  return "off";
}

Perturbation ParsePerturbation(const std::string& name) {
  for (Perturbation p : {Perturbation::kOff, Perturbation::kReversed, Perturbation::kShuffled}) {
    if (name == PerturbationName(p)) return p;
  }
  throw Error("unknown perturbation '" + name + "' (known: reversed, shuffled, off)",
              {.key = "--controllability"});
}

std::vector<float> PerturbActions(const float* actions, int64_t dim, int64_t num_frames,
                                  Perturbation p, uint64_t seed, int64_t episode) {
  std::vector<float> out(actions, actions + num_frames * dim);
  const int64_t n = std::max<int64_t>(num_frames - 1, 0);  // actions that lead to a next frame
  std::vector<int64_t> order(static_cast<size_t>(n));
  for (int64_t i = 0; i < n; ++i) order[i] = i;
  if (p == Perturbation::kReversed) std::reverse(order.begin(), order.end());
  if (p == Perturbation::kShuffled) {
    // Stream -1 of the episode: never one of the sampling streams (samples count from 0).
    std::mt19937_64 rng(MixSeed(MixSeed(seed, episode), -1));
    for (int64_t i = n - 1; i > 0; --i) {
      std::swap(order[i], order[static_cast<int64_t>(rng() % static_cast<uint64_t>(i + 1))]);
    }
  }
  for (int64_t i = 0; i < n; ++i) {
    std::copy_n(actions + order[i] * dim, dim, out.begin() + i * dim);
  }
  return out;
}

std::vector<EpisodeRollout> PerturbedRollout(const train::DynamicsModel& model,
                                             const tokens::TokenDataset& data,
                                             const std::vector<int64_t>& episodes,
                                             RolloutOptions options, Perturbation p,
                                             Progress* progress) {
  options.samples = 1;  // only sample 0 is scored against the plain rollout
  std::vector<std::vector<float>> actions;
  for (int64_t k : episodes) {
    actions.push_back(PerturbActions(data.actions(k), data.action_dim(), data.episode(k).num_frames,
                                     p, options.seed, k));
  }
  return Rollout(model, data, episodes, RolloutMode::kPlain, options, &actions, progress);
}

}  // namespace wm::evaluate

#pragma once
// Controllability (Genie, Bruce et al. 2024, "ΔtPSNR"): imagine the same episode again with its
// actions perturbed and measure how much worse the prediction gets. A model that ignores its
// actions imagines the same frames either way and scores exactly 0; one that follows them loses
// PSNR when given the wrong ones. docs/reports.md, "Controllability".
#include <cstdint>
#include <string>
#include <vector>

#include "evaluate/rollout.h"

namespace wm::evaluate {

enum class Perturbation {
  kOff,       // no perturbed rollout, no delta_tpsnr rows
  kReversed,  // the episode's actions a_0 .. a_{T-2} in reverse order: a_{T-2}, ..., a_0
  kShuffled,  // the same actions in a seeded random order (per episode)
};
const char* PerturbationName(Perturbation p);  // "off", "reversed", "shuffled"
// Throws wm::Error naming `--controllability` for any other name.
Perturbation ParsePerturbation(const std::string& name);

// Episode `episode`'s actions ([num_frames, dim], row-major) with the T - 1 that lead to a next
// frame (rows 0 .. num_frames - 2) permuted by `p`; the last row, which leads nowhere, unchanged.
// The whole episode, not only the evaluated horizon: reversing a few similar actions at the
// start (an arm approaching at a steady speed) would change little, and a horizon of 1 not at
// all. Permuting the episode's own actions keeps them in its distribution; only which action
// leads from which frame is wrong. Shuffling is a Fisher-Yates pass with its own
// std::mt19937_64 stream per (seed, episode), so a shard job draws what a single job draws.
std::vector<float> PerturbActions(const float* actions, int64_t dim, int64_t num_frames,
                                  Perturbation p, uint64_t seed, int64_t episode);

// The plain rollout of `episodes` again, fed PerturbActions(...) of each (sample 0 only, with
// the plain rollout's sampling seeds, so that the actions are the only difference). `progress`
// as Rollout's.
std::vector<EpisodeRollout> PerturbedRollout(const train::DynamicsModel& model,
                                             const tokens::TokenDataset& data,
                                             const std::vector<int64_t>& episodes,
                                             RolloutOptions options, Perturbation p,
                                             Progress* progress = nullptr);

}  // namespace wm::evaluate

#pragma once
// wm-success score: a trained success classifier run over every frame of a shard dataset, one
// verdict per episode, decided as wm-eval --policy decides in imagination (a success when some
// frame's P(success) > 0.5), beside the success the episode's own rewards log. A check of the
// classifier on real episodes (e.g. wm-sim-policy's closed-loop episodes of each policy), apart
// from any world model. Torch-free.
#include <cstdint>
#include <string>
#include <vector>

namespace wm::success {

class SuccessModel;

struct EpisodeScore {
  int64_t episode = 0;  // index in the dataset
  std::string policy_id;
  int64_t steps = 0;
  bool logged_success = false;      // some logged reward > the classifier's data.reward_threshold
  bool predicted_success = false;   // some frame's P(success) > 0.5
  int64_t first_success_step = -1;  // the first such frame, -1 when none
  double max_probability = 0;
};

// Every episode of the shard dataset `dir`, frames resized to the classifier's image size.
// Throws wm::Error naming the dataset when an episode lacks the classifier's image stream.
std::vector<EpisodeScore> ScoreEpisodes(const SuccessModel& model, const std::string& dir);

// scores.csv: `episode,policy_id,steps,logged_success,predicted_success,first_success_step,
// max_probability` (docs/success.md, "wm-success score").
std::string ScoresCsv(const std::vector<EpisodeScore>& scores);

}  // namespace wm::success

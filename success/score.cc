#include "success/score.h"

#include <algorithm>
#include <cstdio>

#include "success/labelled_frames.h"
#include "success/success_model.h"

namespace wm::success {

std::vector<EpisodeScore> ScoreEpisodes(const SuccessModel& model, const std::string& dir) {
  const SuccessConfig& c = model.config();
  const LabelledFrames frames(dir, c.data.image_key, c.model.image_size, c.data.reward_threshold,
                              /*need_both=*/false);
  const std::vector<FrameRef>& all = frames.all();  // episode-major
  const size_t frame_floats = 3ull * c.model.image_size * c.model.image_size;
  std::vector<EpisodeScore> scores;
  for (size_t begin = 0; begin < all.size();) {
    size_t end = begin;
    while (end < all.size() && all[end].episode == all[begin].episode) ++end;
    const std::vector<FrameRef> refs(all.begin() + begin, all.begin() + end);
    std::vector<float> pixels(refs.size() * frame_floats), labels(refs.size());
    frames.Load(refs, pixels.data(), labels.data());
    const std::vector<float> p = model.Probabilities(pixels, static_cast<int64_t>(refs.size()));
    EpisodeScore s{.episode = refs[0].episode,
                   .policy_id = frames.policy_id(refs[0].episode),
                   .steps = static_cast<int64_t>(refs.size())};
    for (size_t t = 0; t < refs.size(); ++t) {
      s.logged_success |= refs[t].success;
      s.max_probability = std::max<double>(s.max_probability, p[t]);
      if (p[t] > 0.5f && s.first_success_step < 0) s.first_success_step = static_cast<int64_t>(t);
    }
    s.predicted_success = s.first_success_step >= 0;
    scores.push_back(std::move(s));
    begin = end;
  }
  return scores;
}

std::string ScoresCsv(const std::vector<EpisodeScore>& scores) {
  std::string csv =
      "episode,policy_id,steps,logged_success,predicted_success,first_success_step,"
      "max_probability\n";
  for (const EpisodeScore& s : scores) {
    char p[32];
    std::snprintf(p, sizeof(p), "%.9g", s.max_probability);
    csv += std::to_string(s.episode) + "," + s.policy_id + "," + std::to_string(s.steps) + "," +
           (s.logged_success ? "1" : "0") + "," + (s.predicted_success ? "1" : "0") + "," +
           std::to_string(s.first_success_step) + "," + p + "\n";
  }
  return csv;
}

}  // namespace wm::success

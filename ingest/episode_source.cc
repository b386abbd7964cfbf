#include "ingest/episode_source.h"

namespace wm::ingest {

void StartEpisode(Episode& e, const EpisodeRef& ref) {
  e.episode_key = ref.rel_path + "#" + std::to_string(ref.record);
  e.source_file = ref.rel_path;
  e.source_record = ref.record;
}

void SetBoundaryFlags(Episode& e, bool terminal) {
  const auto t = static_cast<size_t>(e.num_steps);
  e.discounts.assign(t, 1.0f);
  e.is_first.assign(t, 0);
  e.is_last.assign(t, 0);
  e.is_terminal.assign(t, 0);
  if (t == 0) return;
  e.is_first[0] = 1;
  e.is_last[t - 1] = 1;
  e.is_terminal[t - 1] = terminal ? 1 : 0;
}

}  // namespace wm::ingest

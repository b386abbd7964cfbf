#include "ingest/episode_source.h"

#include "core/error.h"

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

void SetActions(Episode& e, std::vector<float> actions, int64_t width, const std::string& requested,
                const ErrorContext& where) {
  std::string space = requested;
  if (space.empty()) space = width == kActionDim ? "eef_delta" : "other";
  Check(space != "eef_delta" || width == kActionDim,
        "eef_delta actions are 7 values per step (Δxyz, Δrpy, gripper), got " +
            std::to_string(width) + "; pass --action-space other or joint_position",
        where);
  e.action_dim = width;
  e.action_space = std::move(space);
  e.actions = std::move(actions);
}

}  // namespace wm::ingest

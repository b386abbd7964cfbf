#pragma once
// wm-eval --save-rollouts DIR: the frames of every scored episode (each model rollout's first
// imagination, each baseline, the real frames they are scored against and the real frame they
// start from) as image-folder episodes (docs/folder-format.md), so that wm-ingest --format
// folder, wm-metrics or a VLM judge can read them without wmkit's reports.
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "evaluate/frame_scores.h"

namespace wm {
struct Episode;
}

namespace wm::evaluate {

struct EvalOptions;

class RolloutExporter {
 public:
  // Exports under options.save_rollouts/<name>/; does nothing when save_rollouts is empty.
  // `checkpoint_file` and `tokenizer_sha256` are recorded in every episode's meta.json.
  RolloutExporter(const EvalOptions& options, const std::string& name,
                  const std::string& checkpoint_file, const std::string& tokenizer_sha256);

  // Writes DIR/<name>/<kind>/episode_K/ (K = `episode`, the token dataset index) for every kind
  // of `clips` (frames 1..H; a "real" entry is skipped), "real" (`real`'s frames 1..H) and
  // "context" (`real`'s frame 0). `ep`: the real episode in the shard dataset at
  // `source_episode`, for actions, instruction, policy and seed. Each episode folder is written
  // as a hidden `.episode_K.tmp` folder and renamed when complete, so a killed run leaves no
  // partial episode that a folder reader would take.
  void Write(int64_t episode, int64_t source_episode, const Episode& ep, const Clip& real,
             const std::map<std::string, Clip>& clips) const;

 private:
  std::string dir_;        // DIR/<name>, empty when disabled
  nlohmann::json source_;  // provenance shared by every episode (meta.json "wmkit_export")
};

}  // namespace wm::evaluate

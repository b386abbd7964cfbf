#pragma once
// Reads image-folder episodes: one subdirectory per episode holding numbered frames,
// actions.csv, and optionally rewards.csv and meta.json. docs/folder-format.md is the spec.
#include <string>
#include <vector>

#include "ingest/episode_source.h"

namespace wm::ingest {

class FolderSource : public EpisodeSource {
 public:
  // `input`: the directory whose subdirectories are the episodes. `action_space`: of the
  // actions.csv rows (ingest::SetActions); empty: eef_delta when 7 wide, else other.
  explicit FolderSource(std::string input, std::string action_space = "");

  std::string format() const override { return "folder"; }
  // The input directory's name.
  std::string dataset_name() const override;
  // Episode subdirectories in natural name order (ep_2 before ep_10); hidden ones are ignored.
  // Nothing here can be damaged, so `damaged` is never written.
  std::vector<EpisodeRef> ListEpisodes(std::vector<shard::SkippedEpisode>* damaged) override;
  // ref.path is the episode directory, ref.rel_path its name, ref.record 0. Frames keep their
  // encoded bytes. Thread-safe: no shared state.
  Episode Load(const EpisodeRef& ref) const override;
  // {} unless an action space was given.
  nlohmann::json Describe() const override;

 private:
  std::string input_, action_space_;
};

}  // namespace wm::ingest

#pragma once
// LeRobotDataset v2.x (parquet per episode + one MP4 per episode and camera) and v3.0 (many
// episodes per parquet and per MP4) as an EpisodeSource. Layouts and mapping:
// docs/lerobot-mapping.md.
#include <string>
#include <vector>

#include "ingest/episode_source.h"
#include "ingest/lerobot/lerobot_mapping.h"
#include "ingest/lerobot/lerobot_meta.h"

namespace wm::ingest {

class LeRobotSource : public EpisodeSource {
 public:
  // `root` holds meta/, data/ and videos/. `camera` (--camera) overrides the mapping's.
  LeRobotSource(const std::string& root, const std::string& camera, const std::string& mapping_file,
                const std::string& configs_dir);
  std::string format() const override { return "lerobot"; }
  std::string dataset_name() const override { return name_; }
  // The episodes meta/ lists whose parquet and video files exist. Listed episodes
  // without them are logged and returned by Absent(); they are not an error.
  std::vector<EpisodeRef> ListEpisodes(std::vector<shard::SkippedEpisode>* damaged) override;
  std::vector<shard::SkippedEpisode> Absent() const override { return absent_; }
  Episode Load(const EpisodeRef& ref) const override;
  nlohmann::json Describe() const override;

 private:
  void ReadFrames(const LeRobotEpisodeMeta& listed, const std::vector<double>& timestamps,
                  Episode& episode) const;

  std::string name_;
  LeRobotMeta meta_;
  LeRobotMapping mapping_;
  std::string camera_;
  int64_t action_width_ = 0;
  std::vector<shard::SkippedEpisode> absent_;
};

}  // namespace wm::ingest

#pragma once
// meta/ of a LeRobotDataset v2.x: info.json (features, fps, path templates), episodes.jsonl,
// tasks.jsonl. Layout: docs/lerobot-mapping.md ("Layout v2.1").
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace wm::ingest {

struct LeRobotEpisodeMeta {
  int64_t index = 0;
  int64_t length = 0;  // steps, as episodes.jsonl says
  std::vector<std::string> tasks;
};

struct LeRobotMeta {
  std::string root;              // the dataset directory (holds meta/, data/, videos/)
  std::string codebase_version;  // "v2.1", "v2.0"
  double fps = 0;
  int64_t chunks_size = 1000;                // episodes per chunk-XXX directory
  std::string data_path, video_path;         // templates, e.g. data/chunk-{episode_chunk:03d}/...
  nlohmann::json features;                   // info.json "features"
  std::vector<std::string> video_keys;       // features of dtype "video", in info.json order
  std::map<int64_t, std::string> tasks;      // task_index -> task text
  std::vector<LeRobotEpisodeMeta> episodes;  // in episodes.jsonl order

  // Paths relative to `root` of one episode's parquet file and camera video.
  std::string DataPath(int64_t episode) const;
  std::string VideoPath(int64_t episode, const std::string& video_key) const;
  // Values per step of a numeric feature (the product of its shape); throws when undeclared.
  int64_t FeatureWidth(const std::string& key) const;
};

// Reads and checks meta/; throws wm::Error naming the file, line and key.
LeRobotMeta ReadLeRobotMeta(const std::string& root);

// Fills "{name}" and "{name:0Nd}" fields of a LeRobot path template.
std::string FormatPathTemplate(const std::string& pattern,
                               const std::map<std::string, std::string>& text_fields,
                               const std::map<std::string, int64_t>& int_fields);

}  // namespace wm::ingest

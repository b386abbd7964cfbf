#pragma once
// meta/ of a LeRobotDataset: info.json (features, fps, path templates) and the episode and task
// lists: episodes.jsonl / tasks.jsonl in v2.x, meta/episodes/*.parquet / tasks.parquet in v3.0.
// Layouts: docs/lerobot-mapping.md ("Layout v2.1", "Layout v3.0").
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace wm::parquet {
class ParquetFile;
}

namespace wm::ingest {

// Where one camera's frames of an episode lie in a v3.0 video file, which concatenates episodes:
// the episode's step timestamps count from `from_s` in the file.
struct LeRobotVideoSpan {
  int64_t chunk = 0, file = 0;
  double from_s = 0, to_s = 0;  // videos/<key>/from_timestamp, to_timestamp
};

struct LeRobotEpisodeMeta {
  int64_t index = 0;
  int64_t length = 0;     // steps, as meta/ says
  std::string listed_in;  // the meta file listing it, relative to the root (for messages)
  // v3.0 only (meta/episodes/*.parquet): the data file holding the episode's rows, their global
  // `index` range [from_row, to_row), and per camera its span of a video file.
  int64_t data_chunk = 0, data_file = 0;
  int64_t from_row = 0, to_row = 0;
  std::map<std::string, LeRobotVideoSpan> videos;
};

struct LeRobotMeta {
  std::string root;                     // the dataset directory (holds meta/, data/, videos/)
  std::string codebase_version;         // "v2.0", "v2.1" or "v3.0"
  bool many_episodes_per_file = false;  // v3.0
  double fps = 0;
  int64_t chunks_size = 1000;                // episodes per chunk-XXX directory
  std::string data_path, video_path;         // templates, e.g. data/chunk-{episode_chunk:03d}/...
  nlohmann::json features;                   // info.json "features"
  std::vector<std::string> video_keys;       // features of dtype "video", in info.json order
  std::map<int64_t, std::string> tasks;      // task_index -> task text
  std::vector<LeRobotEpisodeMeta> episodes;  // in meta/'s order

  // Paths relative to `root` of the parquet file and camera video holding an episode.
  std::string DataPath(const LeRobotEpisodeMeta& episode) const;
  std::string VideoPath(const LeRobotEpisodeMeta& episode, const std::string& video_key) const;
  // Where the camera's frames of the episode start and end in its video (v2.x: 0 and infinity).
  LeRobotVideoSpan VideoSpan(const LeRobotEpisodeMeta& episode, const std::string& key) const;
  // The episode listed with this episode_index; throws when none is.
  const LeRobotEpisodeMeta& Episode(int64_t index) const;
  // Values per step of a numeric feature (the product of its shape); throws when undeclared.
  int64_t FeatureWidth(const std::string& key) const;
};

// Reads and checks meta/; throws wm::Error naming the file, line or row and key.
LeRobotMeta ReadLeRobotMeta(const std::string& root);
// The v3.0 part: meta/tasks.parquet and meta/episodes/chunk-*/file-*.parquet into `meta`
// (lerobot_meta_v30.cc).
void ReadLeRobotMetaV30(LeRobotMeta& meta);
// Appends the episodes of one meta/episodes parquet file (`rel_path` names it in errors) to
// `meta`, reading the video columns of meta.video_keys. Also the fuzz target's entry point.
void ReadLeRobotEpisodesV30(const parquet::ParquetFile& file, const std::string& rel_path,
                            LeRobotMeta& meta);

// Fills "{name}" and "{name:0Nd}" fields of a LeRobot path template.
std::string FormatPathTemplate(const std::string& pattern,
                               const std::map<std::string, std::string>& text_fields,
                               const std::map<std::string, int64_t>& int_fields);

}  // namespace wm::ingest

// meta/ of a LeRobotDataset v3.0 (lerobot/datasets/utils.py, DEFAULT_TASKS_PATH and
// DEFAULT_EPISODES_PATH): tasks.parquet and meta/episodes/chunk-XXX/file-XXX.parquet.
#include <algorithm>
#include <filesystem>

#include "core/error.h"
#include "ingest/lerobot/columns.h"
#include "ingest/lerobot/lerobot_meta.h"

namespace wm::ingest {
namespace fs = std::filesystem;

namespace {

// pandas writes the task text as the DataFrame's index: a column named after the index ("task"
// in LeRobot's own writer) or "__index_level_0__" when the index has no name.
void ReadTasks(LeRobotMeta& m) {
  const fs::path path = fs::path(m.root) / "meta" / "tasks.parquet";
  Check(fs::exists(path), "missing (a v3.0 dataset lists its tasks there)", {.file = path});
  const parquet::ParquetFile file(path.string());
  std::string text_key = "task";
  if (!file.Find(text_key)) text_key = "__index_level_0__";
  Check(file.Find(text_key) != nullptr,
        "no task text column (expected 'task' or pandas' index column '__index_level_0__')",
        {.file = path});
  const std::vector<double> index = NumberColumn(file, "task_index", 1);
  const std::vector<std::string> text = TextColumn(file, text_key);
  for (size_t i = 0; i < index.size(); ++i) {
    const ErrorContext where{.file = path,
                             .record = static_cast<int64_t>(i),
                             .record_label = "row",
                             .key = "task_index"};
    m.tasks[WholeNumber(index[i], where)] = text[i];
  }
}

}  // namespace

// One meta/episodes parquet file: a row per episode.
void ReadLeRobotEpisodesV30(const parquet::ParquetFile& file, const std::string& rel,
                            LeRobotMeta& m) {
  auto column = [&](const std::string& key) { return NumberColumn(file, key, 1); };
  const std::vector<double> index = column("episode_index"), length = column("length"),
                            data_chunk = column("data/chunk_index"),
                            data_file = column("data/file_index"),
                            from_row = column("dataset_from_index"),
                            to_row = column("dataset_to_index");
  struct VideoColumns {
    std::string key;
    std::vector<double> chunk, file, from, to;
  };
  std::vector<VideoColumns> videos;
  for (const std::string& key : m.video_keys) {
    const std::string prefix = "videos/" + key + "/";
    if (!file.Find(prefix + "from_timestamp")) continue;  // a camera missing: named when chosen
    videos.push_back({key, column(prefix + "chunk_index"), column(prefix + "file_index"),
                      column(prefix + "from_timestamp"), column(prefix + "to_timestamp")});
  }
  for (size_t r = 0; r < index.size(); ++r) {
    const ErrorContext where{.file = rel, .record = static_cast<int64_t>(r), .record_label = "row"};
    LeRobotEpisodeMeta e;
    e.index = WholeNumber(index[r], where);
    e.length = WholeNumber(length[r], where);
    e.listed_in = rel;
    e.data_chunk = WholeNumber(data_chunk[r], where);
    e.data_file = WholeNumber(data_file[r], where);
    e.from_row = WholeNumber(from_row[r], where);
    e.to_row = WholeNumber(to_row[r], where);
    Check(e.index >= 0 && e.length >= 0, "negative episode_index or length", where);
    Check(e.to_row - e.from_row == e.length,
          "dataset_from_index " + std::to_string(e.from_row) + " .. dataset_to_index " +
              std::to_string(e.to_row) + " spans " + std::to_string(e.to_row - e.from_row) +
              " rows, but length is " + std::to_string(e.length),
          where);
    for (const VideoColumns& v : videos) {
      const LeRobotVideoSpan span{WholeNumber(v.chunk[r], where), WholeNumber(v.file[r], where),
                                  v.from[r], v.to[r]};
      Check(span.from_s >= 0 && span.to_s > span.from_s,
            "videos/" + v.key + "/from_timestamp " + std::to_string(span.from_s) +
                " and to_timestamp " + std::to_string(span.to_s) + " (expected 0 <= from < to)",
            where);
      e.videos[v.key] = span;
    }
    m.episodes.push_back(std::move(e));
  }
}

void ReadLeRobotMetaV30(LeRobotMeta& m) {
  ReadTasks(m);
  const fs::path dir = fs::path(m.root) / "meta" / "episodes";
  std::vector<fs::path> files;
  if (fs::is_directory(dir)) {
    for (const auto& entry : fs::recursive_directory_iterator(dir)) {
      if (entry.is_regular_file() && entry.path().extension() == ".parquet") {
        files.push_back(entry.path());
      }
    }
  }
  Check(!files.empty(), "no episode list: expected meta/episodes/chunk-XXX/file-XXX.parquet",
        {.file = dir.string()});
  std::sort(files.begin(), files.end());  // chunk-000/file-000, file-001, ...: episode order
  for (const fs::path& f : files) {
    try {
      ReadLeRobotEpisodesV30(parquet::ParquetFile(f.string()), fs::relative(f, m.root).string(), m);
    } catch (const Error& e) {
      throw e.WithFile(f.string());
    }
  }
}

}  // namespace wm::ingest

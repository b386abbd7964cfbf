#include "ingest/lerobot/lerobot_source.h"

#include <spdlog/spdlog.h>

#include <filesystem>

#include "core/error.h"
#include "ingest/image_codec.h"
#include "ingest/lerobot/columns.h"
#include "ingest/lerobot/frame_matcher.h"
#include "ingest/parquet/parquet_file.h"
#include "ingest/video/video_decoder.h"

namespace wm::ingest {
namespace fs = std::filesystem;
using parquet::Column;

namespace {

// The rows [begin, end) of a data file that hold one episode: all of a v2.x file, a contiguous
// block of a v3.0 one, which lies in the row groups [first_group, end_group).
struct EpisodeRows {
  const parquet::ParquetFile& file;
  int64_t begin = 0, end = 0;
  size_t first_group = 0, end_group = 0;
  // The rows' values of a numeric column, `width` per row; only their row groups are decoded.
  std::vector<double> Numbers(const std::string& key, int64_t width) const {
    const std::vector<double> groups = NumberColumn(file, key, width, first_group, end_group);
    const int64_t offset = file.GroupStart(first_group);
    return {groups.begin() + (begin - offset) * width, groups.begin() + (end - offset) * width};
  }
};

// Finds the block of rows whose `key` column holds `episode`; throws naming the file when the
// episode is absent, its rows are not contiguous, or (`whole_file`) other episodes share the file.
EpisodeRows FindEpisodeRows(const parquet::ParquetFile& file, const std::string& rel_path,
                            const std::string& key, int64_t episode, bool whole_file) {
  const std::vector<double> index = NumberColumn(file, key, 1);
  const ErrorContext where{.file = rel_path, .key = key};
  const auto is_episode = [&](double v) { return v == static_cast<double>(episode); };
  const auto first = std::find_if(index.begin(), index.end(), is_episode);
  const auto last = std::find_if_not(first, index.end(), is_episode);
  std::string held;  // the episodes the file does hold, for the message
  for (size_t i = 0; i < index.size() && held.size() < 80; ++i) {
    if (i == 0 || index[i] != index[i - 1]) {
      held += (held.empty() ? "" : ", ") + NumberText(index[i]);
    }
  }
  Check(first != index.end(),
        "episode " + std::to_string(episode) + " is not in this file (meta/ says it is; " + key +
            " holds " + (held.empty() ? "nothing" : held) + ")",
        where);
  Check(std::find_if(last, index.end(), is_episode) == index.end(),
        "the rows of episode " + std::to_string(episode) + " are not contiguous", where);
  EpisodeRows rows{file, first - index.begin(), last - index.begin(), 0, file.num_row_groups()};
  while (rows.first_group + 1 < rows.end_group &&
         file.GroupStart(rows.first_group + 1) <= rows.begin)
    ++rows.first_group;
  while (rows.end_group > rows.first_group + 1 && file.GroupStart(rows.end_group - 1) >= rows.end)
    --rows.end_group;
  if (whole_file && (rows.begin != 0 || rows.end != file.num_rows())) {
    const double other = rows.begin != 0 ? index.front() : index.back();
    throw Error(
        "episode_index " + NumberText(other) + " in the file of episode " + std::to_string(episode),
        where);
  }
  return rows;
}

// "0, 3, 5-99": episode indices as short ranges, for the log.
std::string Ranges(const std::vector<int64_t>& v) {
  std::string out;
  for (size_t i = 0; i < v.size();) {
    size_t j = i;
    while (j + 1 < v.size() && v[j + 1] == v[j] + 1) ++j;
    out += (out.empty() ? "" : ", ") + std::to_string(v[i]) +
           (j > i ? "-" + std::to_string(v[j]) : "");
    i = j + 1;
  }
  return out;
}

}  // namespace

LeRobotSource::LeRobotSource(const std::string& root, const std::string& camera,
                             const std::string& mapping_file, const std::string& configs_dir)
    : name_(fs::path(root).lexically_normal().filename().string()), meta_(ReadLeRobotMeta(root)) {
  if (name_.empty()) name_ = fs::path(root).lexically_normal().parent_path().filename().string();
  mapping_ = LoadLeRobotMapping(FindLeRobotMapping(mapping_file, configs_dir, name_));
  spdlog::info("LeRobot {} dataset {}: {} episodes listed, {} fps, mapping {}",
               meta_.codebase_version, name_, meta_.episodes.size(), meta_.fps, mapping_.file);
  camera_ = !camera.empty() ? camera : mapping_.camera;
  std::string known;
  for (const auto& k : meta_.video_keys) known += (known.empty() ? "" : ", ") + k;
  if (camera_.empty()) {
    Check(meta_.video_keys.size() == 1,
          "info.json has " + std::to_string(meta_.video_keys.size()) +
              " video features; choose one with --camera (" + known + ")",
          {.file = root + "/meta/info.json"});
    camera_ = meta_.video_keys.front();
  }
  Check(std::find(meta_.video_keys.begin(), meta_.video_keys.end(), camera_) !=
            meta_.video_keys.end(),
        "camera '" + camera_ + "' is not a video feature of info.json (" + known + ")",
        {.file = root + "/meta/info.json"});
  action_width_ = meta_.FeatureWidth(mapping_.action);
  Check(action_width_ > 0, "action feature '" + mapping_.action + "' has no width",
        {.file = mapping_.file});
}

std::vector<EpisodeRef> LeRobotSource::ListEpisodes(std::vector<shard::SkippedEpisode>*) {
  std::vector<EpisodeRef> refs;
  std::vector<int64_t> missing;
  absent_.clear();
  for (const auto& e : meta_.episodes) {
    const std::string data = meta_.DataPath(e), video = meta_.VideoPath(e, camera_);
    std::string lacking;
    if (!fs::exists(fs::path(meta_.root) / data))
      lacking = data;
    else if (!fs::exists(fs::path(meta_.root) / video))
      lacking = video;
    if (lacking.empty()) {
      refs.push_back({(fs::path(meta_.root) / data).string(), data, e.index, 0});
      continue;
    }
    missing.push_back(e.index);
    absent_.push_back(
        {data, e.index, "listed in " + e.listed_in + ", but " + lacking + " does not exist"});
  }
  if (!missing.empty()) {
    spdlog::warn(
        "{} of the {} episodes that meta/ lists are absent (no parquet or {} video), "
        "ingesting the {} present; absent: {}",
        missing.size(), meta_.episodes.size(), camera_, refs.size(), Ranges(missing));
  }
  return refs;
}

Episode LeRobotSource::Load(const EpisodeRef& ref) const {
  Episode e;
  StartEpisode(e, ref);
  const LeRobotEpisodeMeta& listed = meta_.Episode(ref.record);
  const parquet::ParquetFile file(ref.path);
  const EpisodeRows rows = FindEpisodeRows(file, ref.rel_path, mapping_.episode_index, ref.record,
                                           !meta_.many_episodes_per_file);
  const int64_t t = rows.end - rows.begin;
  const ErrorContext where{.file = ref.rel_path, .record = ref.record, .record_label = "episode"};
  Check(listed.length == t,
        "has " + std::to_string(t) + " rows, " + listed.listed_in + " says length " +
            std::to_string(listed.length),
        where);
  if (meta_.many_episodes_per_file && file.Find("index")) {
    const double first = rows.Numbers("index", 1).front();  // FindEpisodeRows found >= 1 row
    Check(first == static_cast<double>(listed.from_row),
          "the first row has index " + NumberText(first) + ", " + listed.listed_in +
              " says dataset_from_index " + std::to_string(listed.from_row),
          where);
  }
  e.num_steps = t;
  const std::vector<double> action = rows.Numbers(mapping_.action, action_width_);
  e.actions.assign(action.begin(), action.end());
  e.action_dim = action_width_;
  e.action_space = mapping_.action_space;
  const std::vector<double> frame_index = rows.Numbers(mapping_.frame_index, 1);
  for (int64_t i = 0; i < t; ++i) {
    Check(frame_index[i] == static_cast<double>(i),
          "row " + std::to_string(rows.begin + i) + " has frame_index " +
              NumberText(frame_index[i]) + " (expected 0, 1, ... in order)",
          {.file = ref.rel_path, .key = mapping_.frame_index});
  }
  if (mapping_.state && file.Find(*mapping_.state)) {
    rows.Numbers(*mapping_.state, meta_.FeatureWidth(*mapping_.state));  // checked, not stored
  }
  const std::vector<double> task = rows.Numbers(mapping_.task_index, 1);
  if (t > 0) {
    const auto it = meta_.tasks.find(WholeNumber(task[0], where));
    Check(it != meta_.tasks.end(),
          "task_index " + NumberText(task[0]) + " is not in meta/'s task list", where);
    e.language_instruction = it->second;
  }
  if (mapping_.reward) {
    const std::vector<double> r = rows.Numbers(*mapping_.reward, 1);
    e.rewards.assign(r.begin(), r.end());
  } else {
    e.rewards.assign(static_cast<size_t>(t), 0.0f);
  }
  SetBoundaryFlags(e, /*terminal=*/false);
  if (mapping_.is_terminal) {
    const std::vector<double> done = rows.Numbers(*mapping_.is_terminal, 1);
    for (int64_t i = 0; i < t; ++i) e.is_terminal[i] = done[i] != 0 ? 1 : 0;
  }
  ReadFrames(listed, rows.Numbers(mapping_.timestamp, 1), e);
  return e;
}

void LeRobotSource::ReadFrames(const LeRobotEpisodeMeta& listed,
                               const std::vector<double>& timestamps, Episode& e) const {
  const std::string video = meta_.VideoPath(listed, camera_);
  const LeRobotVideoSpan span = meta_.VideoSpan(listed, camera_);
  // v3.0: step timestamps count from the episode's start in the concatenated file
  // (LeRobotDataset._query_videos adds from_timestamp).
  std::vector<double> in_file(timestamps);
  for (double& ts : in_file) ts += span.from_s;
  EncodedFrames& frames = e.images["image"];
  frames.encoding = "jpeg";
  frames.frames.assign(timestamps.size(), "");
  FrameMatcher matcher(in_file, mapping_.tolerance_s);
  const VideoStreamInfo info =
      DecodeVideo((fs::path(meta_.root) / video).string(),
                  [&](const RgbFrame& f) {
                    std::vector<size_t> steps = matcher.Offer(f.timestamp_s);
                    if (steps.empty()) return;
                    std::string jpeg = EncodeRgb(f.pixels, f.height, f.width, 3, "jpeg");
                    for (size_t s : steps) frames.frames[s] = jpeg;
                  },
                  {span.from_s, span.to_s});
  const ErrorContext where{
      .file = video, .record = listed.index, .record_label = "episode", .key = camera_};
  if (meta_.many_episodes_per_file) {
    // The last frame starts one frame period before to_timestamp.
    Check(info.last_timestamp_s + 1.5 / meta_.fps >= span.to_s,
          "the video ends with a frame at " + std::to_string(info.last_timestamp_s) + " s, but " +
              listed.listed_in + " says the episode runs to to_timestamp " +
              std::to_string(span.to_s) + " s",
          where);
  }
  try {
    matcher.CheckAllMatched();
  } catch (const Error& err) {
    throw err.WithRecord(listed.index, "episode").WithKey(camera_).WithFile(video);
  }
  spdlog::debug("{}: {} frames of {} {}x{} (decoder {}) for {} steps", video, info.frames,
                info.codec, info.width, info.height, info.decoder, timestamps.size());
}

nlohmann::json LeRobotSource::Describe() const {
  return {{"mapping", mapping_.ToJson()},
          {"camera", camera_},
          {"codebase_version", meta_.codebase_version},
          {"fps", meta_.fps}};
}

}  // namespace wm::ingest

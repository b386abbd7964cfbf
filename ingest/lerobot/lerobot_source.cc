#include "ingest/lerobot/lerobot_source.h"

#include <spdlog/spdlog.h>

#include <filesystem>

#include "core/error.h"
#include "ingest/image_codec.h"
#include "ingest/lerobot/frame_matcher.h"
#include "ingest/parquet/parquet_file.h"
#include "ingest/video/video_decoder.h"

namespace wm::ingest {
namespace fs = std::filesystem;
using parquet::Column;

namespace {

// A numeric column as doubles, `width` values per row (ints converted).
std::vector<double> Numbers(const parquet::ParquetFile& file, const std::string& key,
                            int64_t width) {
  Column c = file.Read(key);
  for (int64_t r = 0; r < c.rows(); ++r) {
    Check(c.RowSize(r) == width,
          "row " + std::to_string(r) + " holds " + std::to_string(c.RowSize(r)) +
              " values, expected " + std::to_string(width),
          {.file = file.name(), .key = key});
  }
  if (!c.values.reals.empty() || c.values.size() == 0) return c.values.reals;
  Check(c.values.strings.empty(), "expected numbers, found strings",
        {.file = file.name(), .key = key});
  return {c.values.ints.begin(), c.values.ints.end()};
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
    const std::string data = meta_.DataPath(e.index), video = meta_.VideoPath(e.index, camera_);
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
        {data, e.index, "listed in meta/episodes.jsonl, but " + lacking + " does not exist"});
  }
  if (!missing.empty()) {
    spdlog::warn(
        "{} of the {} episodes in meta/episodes.jsonl are absent (no parquet or {} "
        "video), ingesting the {} present; absent: {}",
        missing.size(), meta_.episodes.size(), camera_, refs.size(), Ranges(missing));
  }
  return refs;
}

Episode LeRobotSource::Load(const EpisodeRef& ref) const {
  Episode e;
  StartEpisode(e, ref);
  const parquet::ParquetFile file(ref.path);
  const int64_t t = file.num_rows();
  e.num_steps = t;
  const std::vector<double> action = Numbers(file, mapping_.action, action_width_);
  e.actions.assign(action.begin(), action.end());
  e.action_dim = action_width_;
  e.action_space = mapping_.action_space;
  const ErrorContext where{.file = ref.rel_path};
  const std::vector<double> frame_index = Numbers(file, mapping_.frame_index, 1);
  for (int64_t i = 0; i < t; ++i) {
    Check(frame_index[i] == static_cast<double>(i),
          "row " + std::to_string(i) + " has frame_index " + std::to_string(frame_index[i]) +
              " (expected 0, 1, ... in order)",
          {.file = ref.rel_path, .key = mapping_.frame_index});
  }
  for (double v : Numbers(file, mapping_.episode_index, 1)) {
    Check(v == static_cast<double>(ref.record),
          "episode_index " + std::to_string(static_cast<int64_t>(v)) + " in the file of episode " +
              std::to_string(ref.record),
          {.file = ref.rel_path, .key = mapping_.episode_index});
  }
  if (mapping_.state && file.Find(*mapping_.state)) {
    Numbers(file, *mapping_.state, meta_.FeatureWidth(*mapping_.state));  // checked, not stored
  }
  const std::vector<double> task = Numbers(file, mapping_.task_index, 1);
  if (t > 0) {
    const auto it = meta_.tasks.find(static_cast<int64_t>(task[0]));
    Check(it != meta_.tasks.end(),
          "task_index " + std::to_string(task[0]) + " is not in meta/tasks.jsonl", where);
    e.language_instruction = it->second;
  }
  for (const auto& listed : meta_.episodes) {
    if (listed.index != ref.record) continue;
    Check(listed.length == t,
          "has " + std::to_string(t) + " rows, meta/episodes.jsonl says " +
              std::to_string(listed.length),
          where);
  }
  if (mapping_.reward) {
    const std::vector<double> r = Numbers(file, *mapping_.reward, 1);
    e.rewards.assign(r.begin(), r.end());
  } else {
    e.rewards.assign(static_cast<size_t>(t), 0.0f);
  }
  SetBoundaryFlags(e, /*terminal=*/false);
  if (mapping_.is_terminal) {
    const std::vector<double> done = Numbers(file, *mapping_.is_terminal, 1);
    for (int64_t i = 0; i < t; ++i) e.is_terminal[i] = done[i] != 0 ? 1 : 0;
  }
  ReadFrames(ref, Numbers(file, mapping_.timestamp, 1), e);
  return e;
}

void LeRobotSource::ReadFrames(const EpisodeRef& ref, const std::vector<double>& timestamps,
                               Episode& e) const {
  const std::string video = meta_.VideoPath(ref.record, camera_);
  EncodedFrames& frames = e.images["image"];
  frames.encoding = "jpeg";
  frames.frames.assign(timestamps.size(), "");
  FrameMatcher matcher(timestamps, mapping_.tolerance_s);
  const VideoStreamInfo info =
      DecodeVideo((fs::path(meta_.root) / video).string(), [&](const RgbFrame& f) {
        std::vector<size_t> steps = matcher.Offer(f.timestamp_s);
        if (steps.empty()) return;
        std::string jpeg = EncodeRgb(f.pixels, f.height, f.width, 3, "jpeg");
        for (size_t s : steps) frames.frames[s] = jpeg;
      });
  try {
    matcher.CheckAllMatched();
  } catch (const Error& err) {
    throw err.WithKey(camera_).WithFile(video);
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

#include "ingest/lerobot/lerobot_meta.h"

#include <filesystem>
#include <fstream>
#include <limits>

#include "core/error.h"
#include "core/json_int.h"

namespace wm::ingest {
namespace fs = std::filesystem;
using nlohmann::json;
using nlohmann::ordered_json;

namespace {

// Calls on_line(json, line number) for every non-empty line of a JSON-lines file.
template <typename F>
void ReadJsonLines(const fs::path& file, F on_line) {
  std::ifstream in(file);
  Check(in.good(), "cannot open", {.file = file.string()});
  std::string line;
  for (int64_t n = 1; std::getline(in, line); ++n) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    json j = json::parse(line, nullptr, /*allow_exceptions=*/false);
    const ErrorContext where{.file = file.string(), .record = n, .record_label = "line"};
    Check(j.is_object(), "not a JSON object", where);
    try {
      on_line(j);
    } catch (const json::exception& e) {
      throw Error(std::string("unexpected JSON: ") + e.what(), where);
    } catch (const Error& e) {
      throw e.WithRecord(n, "line").WithFile(file.string());
    }
  }
}

}  // namespace

std::string FormatPathTemplate(const std::string& pattern,
                               const std::map<std::string, std::string>& text_fields,
                               const std::map<std::string, int64_t>& int_fields) {
  std::string out;
  for (size_t pos = 0; pos < pattern.size();) {
    const size_t open = pattern.find('{', pos);
    if (open == std::string::npos) {
      out += pattern.substr(pos);
      break;
    }
    const size_t close = pattern.find('}', open);
    Check(close != std::string::npos, "unclosed '{' in path template '" + pattern + "'");
    out += pattern.substr(pos, open - pos);
    const std::string field = pattern.substr(open + 1, close - open - 1);
    const std::string name = field.substr(0, field.find(':'));
    if (auto t = text_fields.find(name); t != text_fields.end()) {
      out += t->second;
    } else if (auto i = int_fields.find(name); i != int_fields.end()) {
      std::string digits = std::to_string(i->second);
      int width = 0;  // "{x:03d}": zero-padded to 3
      if (field.size() > name.size() + 2 && field[name.size() + 1] == '0') {
        width = std::atoi(field.c_str() + name.size() + 2);
      }
      if (static_cast<int>(digits.size()) < width) digits.insert(0, width - digits.size(), '0');
      out += digits;
    } else {
      throw Error("unknown field {" + field + "} in path template '" + pattern + "'");
    }
    pos = close + 1;
  }
  return out;
}

// v2.x templates name {episode_chunk} and {episode_index}, v3.0 ones {chunk_index} and
// {file_index}.
std::string LeRobotMeta::DataPath(const LeRobotEpisodeMeta& e) const {
  return FormatPathTemplate(data_path, {},
                            {{"episode_chunk", e.index / chunks_size},
                             {"episode_index", e.index},
                             {"chunk_index", e.data_chunk},
                             {"file_index", e.data_file}});
}

std::string LeRobotMeta::VideoPath(const LeRobotEpisodeMeta& e, const std::string& key) const {
  const LeRobotVideoSpan span = VideoSpan(e, key);
  return FormatPathTemplate(video_path, {{"video_key", key}},
                            {{"episode_chunk", e.index / chunks_size},
                             {"episode_index", e.index},
                             {"chunk_index", span.chunk},
                             {"file_index", span.file}});
}

LeRobotVideoSpan LeRobotMeta::VideoSpan(const LeRobotEpisodeMeta& e, const std::string& key) const {
  if (!many_episodes_per_file) return {0, 0, 0, std::numeric_limits<double>::infinity()};
  const auto it = e.videos.find(key);
  Check(it != e.videos.end(),
        "episode " + std::to_string(e.index) + " has no videos/" + key + "/... columns",
        {.file = e.listed_in});
  return it->second;
}

const LeRobotEpisodeMeta& LeRobotMeta::Episode(int64_t index) const {
  for (const auto& e : episodes) {
    if (e.index == index) return e;
  }
  throw Error("episode " + std::to_string(index) + " is not listed in meta/", {.file = root});
}

int64_t LeRobotMeta::FeatureWidth(const std::string& key) const {
  Check(features.contains(key), "info.json declares no feature '" + key + "'",
        {.file = root + "/meta/info.json"});
  int64_t width = 1;
  for (const auto& d : features[key].value("shape", json::array())) width *= JsonInt<int64_t>(d);
  return width;
}

LeRobotMeta ReadLeRobotMeta(const std::string& root) {
  LeRobotMeta m;
  m.root = root;
  const fs::path info_file = fs::path(root) / "meta" / "info.json";
  Check(fs::exists(info_file), "not a LeRobot dataset: meta/info.json is missing",
        {.file = info_file.string()});
  std::ifstream in(info_file);
  // ordered_json keeps info.json's feature order, so "the first camera" means the file's first.
  ordered_json info = ordered_json::parse(in, nullptr, /*allow_exceptions=*/false);
  const ErrorContext where{.file = info_file.string()};
  Check(info.is_object(), "not valid JSON", where);
  std::string key;
  try {
    key = "codebase_version", m.codebase_version = info.at(key).get<std::string>();
    m.many_episodes_per_file = m.codebase_version.rfind("v3.", 0) == 0;
    Check(m.codebase_version.rfind("v2.", 0) == 0 || m.many_episodes_per_file,
          "LeRobot " + m.codebase_version + " is not supported (v2.0, v2.1 and v3.0 are)");
    key = "fps", m.fps = info.at(key).get<double>();
    Check(m.fps > 0, "must be positive");
    key = "chunks_size", m.chunks_size = info.value(key, int64_t{1000});
    Check(m.chunks_size > 0, "must be positive");
    key = "data_path", m.data_path = info.at(key).get<std::string>();
    key = "video_path";
    if (info.contains(key) && !info[key].is_null()) m.video_path = info[key].get<std::string>();
    key = "features";
    for (const auto& [name, f] : info.at(key).items()) {
      key = "features." + name;
      if (f.value("dtype", "") == "video") m.video_keys.push_back(name);
    }
    m.features = json::parse(info.at("features").dump());
  } catch (const ordered_json::exception& e) {
    throw Error(std::string("unexpected info.json: ") + e.what(), {.file = where.file, .key = key});
  } catch (const Error& e) {
    throw e.WithKey(key).WithFile(where.file);
  }
  if (m.many_episodes_per_file) {
    ReadLeRobotMetaV30(m);
    return m;
  }
  const fs::path meta = fs::path(root) / "meta";
  ReadJsonLines(meta / "tasks.jsonl", [&](const json& j) {
    m.tasks[JsonInt<int64_t>(j.at("task_index"))] = j.at("task").get<std::string>();
  });
  ReadJsonLines(meta / "episodes.jsonl", [&](const json& j) {
    LeRobotEpisodeMeta e;
    e.index = JsonInt<int64_t>(j.at("episode_index"));
    e.length = JsonInt<int64_t>(j.at("length"));
    e.listed_in = "meta/episodes.jsonl";
    Check(e.index >= 0 && e.length >= 0, "negative episode_index or length");
    m.episodes.push_back(std::move(e));
  });
  return m;
}

}  // namespace wm::ingest

#include "core/shard/dataset_index.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/json_int.h"
#include "core/shard/shard_format.h"

namespace wm::shard {
namespace {
using nlohmann::json;

double Quantile(const std::vector<double>& sorted, double q) {
  double h = (static_cast<double>(sorted.size()) - 1.0) * q;
  auto lo = static_cast<size_t>(std::floor(h));
  size_t hi = std::min(lo + 1, sorted.size() - 1);
  return sorted[lo] + (h - static_cast<double>(lo)) * (sorted[hi] - sorted[lo]);
}

}  // namespace

json StatsToJson(const ActionStats& s) {
  return {{"mean", s.mean}, {"std", s.std}, {"min", s.min},
          {"max", s.max},   {"q01", s.q01}, {"q99", s.q99}};
}

ActionStats StatsFromJson(const json& j) {
  ActionStats s;
  s.mean = j.at("mean").get<ActionStats::Vec>();
  s.std = j.at("std").get<ActionStats::Vec>();
  s.min = j.at("min").get<ActionStats::Vec>();
  s.max = j.at("max").get<ActionStats::Vec>();
  s.q01 = j.at("q01").get<ActionStats::Vec>();
  s.q99 = j.at("q99").get<ActionStats::Vec>();
  for (const auto* v : {&s.std, &s.min, &s.max, &s.q01, &s.q99}) {
    Check(v->size() == s.mean.size(), "action_stats vectors differ in length");
  }
  return s;
}

json IndexToJson(const DatasetIndex& x) {
  json shards = json::array();
  for (const auto& s : x.shards) {
    shards.push_back({{"file", s.file},
                      {"bytes", s.bytes},
                      {"sha256", s.sha256},
                      {"num_episodes", s.num_episodes},
                      {"num_steps", s.num_steps}});
  }
  json skipped = json::array();
  for (const auto& s : x.skipped) {
    skipped.push_back({{"file", s.file}, {"record", s.record}, {"reason", s.reason}});
  }
  return {
      {"format", kFormatName},
      {"format_version", IsCanonicalAction(x.features) ? kFormatVersion : kIndexVersionAnyAction},
      {"dataset", x.dataset},
      {"split", x.split},
      {"source", x.source},
      {"features", x.features},
      {"shards", shards},
      {"num_episodes", x.num_episodes},
      {"num_steps", x.num_steps},
      {"action_stats", StatsToJson(x.action_stats)},
      {"skipped", {{"count", x.skipped.size()}, {"episodes", skipped}}},
      {"provenance", x.provenance}};
}

DatasetIndex IndexFromJson(const json& j, const std::string& file) {
  Check(j.is_object(), "index is not a JSON object", {.file = file});
  Check(j.contains("format") && j["format"] == kFormatName,
        std::string("not a wmkit shard index (format must be \"") + kFormatName + "\")",
        {.file = file, .key = "format"});
  const json& version = j.contains("format_version") ? j["format_version"] : json();
  if (!version.is_number_unsigned() || (version.get<uint32_t>() != kFormatVersion &&
                                        version.get<uint32_t>() != kIndexVersionAnyAction)) {
    throw Error("unknown format_version " + version.dump() + " (this build reads versions " +
                    std::to_string(kFormatVersion) + " and " +
                    std::to_string(kIndexVersionAnyAction) + ")",
                {.file = file, .key = "format_version"});
  }
  DatasetIndex x;
  std::string key;
  try {
    key = "dataset", x.dataset = j.at(key).get<std::string>();
    key = "split", x.split = j.at(key).get<std::string>();
    key = "source", x.source = j.at(key);
    key = "features", x.features = j.at(key);
    key = "shards";
    for (const auto& s : j.at(key)) {
      x.shards.push_back({s.at("file").get<std::string>(), JsonInt<uint64_t>(s.at("bytes")),
                          s.at("sha256").get<std::string>(),
                          JsonInt<uint64_t>(s.at("num_episodes")),
                          JsonInt<uint64_t>(s.at("num_steps"))});
    }
    key = "num_episodes", x.num_episodes = JsonInt<uint64_t>(j.at(key));
    key = "num_steps", x.num_steps = JsonInt<uint64_t>(j.at(key));
    key = "action_stats", x.action_stats = StatsFromJson(j.at(key));
    key = "skipped";
    for (const auto& s : j.at(key).at("episodes")) {
      x.skipped.push_back({s.at("file").get<std::string>(), JsonInt<int64_t>(s.at("record")),
                           s.at("reason").get<std::string>()});
    }
    key = "provenance", x.provenance = j.at(key);
  } catch (const json::exception& e) {
    throw Error(std::string("malformed index: ") + e.what(), {.file = file, .key = key});
  }
  uint64_t episodes = 0, steps = 0;
  for (const auto& s : x.shards) {
    Check(s.file.find('/') == std::string::npos && !s.file.empty() && s.file[0] != '.',
          "shard file name must be a plain file name, got '" + s.file + "'",
          {.file = file, .key = "shards"});
    episodes += s.num_episodes;
    steps += s.num_steps;
  }
  Check(episodes == x.num_episodes && steps == x.num_steps,
        "num_episodes/num_steps disagree with the sum over shards", {.file = file});
  return x;
}

DatasetIndex ReadIndex(const std::string& dir) {
  std::string path = (std::filesystem::path(dir) / kIndexFileName).string();
  if (!std::filesystem::exists(path)) {
    throw Error(
        "not a wmkit dataset: index.json is missing (an interrupted wm-ingest? run it "
        "again with the same options to resume)",
        {.file = path});
  }
  json j = json::parse(ReadFile(path), nullptr, /*allow_exceptions=*/false);
  Check(!j.is_discarded(), "index.json is not valid JSON", {.file = path});
  return IndexFromJson(j, path);
}

void WriteIndex(const std::string& dir, const DatasetIndex& index) {
  WriteFileAtomically((std::filesystem::path(dir) / kIndexFileName).string(),
                      IndexToJson(index).dump(2) + "\n");
}

ActionStats ComputeActionStats(const std::vector<float>& actions, int64_t dim) {
  ActionStats s;
  const auto width = static_cast<size_t>(dim);
  for (auto* v : {&s.mean, &s.std, &s.min, &s.max, &s.q01, &s.q99}) v->assign(width, 0.0);
  const size_t n = actions.size() / width;
  if (n == 0) return s;
  std::vector<double> column(n);
  for (size_t d = 0; d < width; ++d) {
    double sum = 0;
    for (size_t i = 0; i < n; ++i) sum += column[i] = actions[i * width + d];
    double mean = sum / static_cast<double>(n), sq = 0;
    for (double v : column) sq += (v - mean) * (v - mean);
    std::sort(column.begin(), column.end());
    s.mean[d] = mean;
    s.std[d] = std::sqrt(sq / static_cast<double>(n));
    s.min[d] = column.front();
    s.max[d] = column.back();
    s.q01[d] = Quantile(column, 0.01);
    s.q99[d] = Quantile(column, 0.99);
  }
  return s;
}

int64_t ActionDimOf(const json& features) {
  const json& a = features.contains("action") ? features["action"] : json();
  return a.is_object() && a.contains("dim") ? JsonInt<int64_t>(a["dim"]) : kActionDim;
}

std::string ActionSpaceOf(const json& features) {
  const json& a = features.contains("action") ? features["action"] : json();
  return a.is_object() && a.contains("space") ? a["space"].get<std::string>() : "eef_delta";
}

bool IsCanonicalAction(const json& features) {
  return IsCanonicalAction(ActionDimOf(features), ActionSpaceOf(features));
}

bool IsCanonicalAction(int64_t dim, const std::string& space) {
  return dim == kActionDim && space == "eef_delta";
}

bool IsKnownActionSpace(const std::string& space) {
  return space == "eef_delta" || space == "joint_position" || space == "other";
}

json FeaturesOf(const Episode& e) {
  json action;
  if (IsCanonicalAction(e.action_dim, e.action_space)) {
    action = {{"dim", kActionDim}, {"names", kActionNames}};  // the version-1 form, unchanged
  } else {
    std::vector<std::string> names;
    for (int64_t d = 0; d < e.action_dim; ++d) names.push_back("a" + std::to_string(d));
    action = {{"dim", e.action_dim}, {"names", names}, {"space", e.action_space}};
  }
  json f = {{"action", action}};
  for (const auto& [name, frames] : e.images) {
    f[name] = {{"encoding", frames.encoding},
               {"dtype", frames.dtype},
               {"shape", {frames.height, frames.width, frames.channels}}};
  }
  return f;
}

}  // namespace wm::shard

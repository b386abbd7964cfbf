#include "evaluate/episode_record.h"

#include <cmath>
#include <filesystem>
#include <stdexcept>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/sha256.h"

namespace wm::evaluate {
namespace {
using nlohmann::json;
using Series = std::map<std::string, std::vector<double>>;
constexpr const char* kFormat = "wmkit-eval-part";
constexpr int kVersion = 1;

// JSON has no NaN or infinity: they are the strings "nan", "inf", "-inf"; finite numbers print
// in the shortest form that reads back to the same double.
json Number(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return v;
}

double NumberFrom(const json& j) {
  if (!j.is_string()) return j.get<double>();
  const auto& s = j.get_ref<const std::string&>();
  if (s != "nan" && s != "inf" && s != "-inf") {
    throw std::invalid_argument("expected a number, 'nan', 'inf' or '-inf', got '" + s + "'");
  }
  return s == "nan" ? NAN : s == "inf" ? INFINITY : -INFINITY;
}

json SeriesJson(const Series& m) {
  json out = json::object();
  for (const auto& [key, values] : m) {
    json& a = out[key] = json::array();
    for (double v : values) a.push_back(Number(v));
  }
  return out;
}

Series SeriesFrom(const json& j) {
  Series out;
  for (const auto& [key, values] : j.items()) {
    for (const auto& v : values) out[key].push_back(NumberFrom(v));
  }
  return out;
}

json RecordJson(const EpisodeRecord& r) {
  json scores = json::object(), returns = json::object();
  for (const auto& [kind, series] : r.scores) scores[kind] = SeriesJson(series);
  for (const auto& [kind, value] : r.model_return) returns[kind] = Number(value);
  return {{"episode", r.episode},
          {"policy_id", r.policy_id},
          {"steps", r.steps},
          {"scores", scores},
          {"clip_descriptors", SeriesJson(r.clip_descriptors)},
          {"model_return", returns},
          {"real_return", Number(r.real_return)},
          {"spread", SeriesJson(r.spread)},
          {"sample_mse", SeriesJson(r.sample_mse)},
          {"contexts", r.contexts}};
}

EpisodeRecord RecordFrom(const json& j) {
  EpisodeRecord r;
  j.at("episode").get_to(r.episode);
  j.at("policy_id").get_to(r.policy_id);
  j.at("steps").get_to(r.steps);
  for (const auto& [kind, series] : j.at("scores").items()) r.scores[kind] = SeriesFrom(series);
  r.clip_descriptors = SeriesFrom(j.at("clip_descriptors"));
  for (const auto& [kind, v] : j.at("model_return").items()) r.model_return[kind] = NumberFrom(v);
  r.real_return = NumberFrom(j.at("real_return"));
  r.spread = SeriesFrom(j.at("spread"));
  r.sample_mse = SeriesFrom(j.at("sample_mse"));
  j.at("contexts").get_to(r.contexts);
  return r;
}

}  // namespace

void WriteEvalPart(const std::string& path, const EvalPart& part) {
  json records = json::array();
  for (const auto& r : part.records) records.push_back(RecordJson(r));
  const json file = {{"format", kFormat},
                     {"version", kVersion},
                     {"identity", part.identity},
                     {"shard_index", part.shard_index},
                     {"records_sha256", Sha256Hex(records.dump())},
                     {"records", records}};
  WriteFileAtomically(path, file.dump() + "\n");
}

EvalPart ReadEvalPart(const std::string& path) {
  EvalPart part;
  try {
    const json file = json::parse(ReadFile(path));
    Check(file.is_object() && file.value("format", "") == kFormat,
          std::string("not a wm-eval part file: expected format '") + kFormat + "'",
          {.file = path, .key = "format"});
    Check(file.value("version", 0) == kVersion,
          "unsupported part version (this wm-eval reads " + std::to_string(kVersion) + ")",
          {.file = path, .key = "version"});
    const json& records = file.at("records");
    Check(Sha256Hex(records.dump()) == file.at("records_sha256").get<std::string>(),
          "checksum mismatch: the records do not match records_sha256 (corrupt part file)",
          {.file = path, .key = "records_sha256"});
    part.identity = file.at("identity");
    file.at("shard_index").get_to(part.shard_index);
    for (const auto& r : records) part.records.push_back(RecordFrom(r));
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {  // json's type and key errors, bad number strings
    throw Error(std::string("malformed wm-eval part file: ") + e.what(), {.file = path});
  }
  return part;
}

namespace fs = std::filesystem;

std::string PartPath(const std::string& dir, int index, int count) {
  return (fs::path(dir) / "parts" /
          ("part-" + std::to_string(index) + "-of-" + std::to_string(count) + ".json"))
      .string();
}

std::optional<std::vector<EpisodeRecord>> GatherParts(const std::string& dir,
                                                      const nlohmann::json& identity,
                                                      const std::vector<int64_t>& episodes,
                                                      int num_shards) {
  std::map<int64_t, EpisodeRecord> by_episode;
  for (int i = 0; i < num_shards; ++i) {
    const std::string path = PartPath(dir, i, num_shards);
    if (!fs::exists(path)) return std::nullopt;
    EvalPart part = ReadEvalPart(path);
    Check(part.identity == identity && part.shard_index == i,
          "part was written by a run with other settings, checkpoint or data than this one "
          "(remove the parts folder to start over)",
          {.file = path, .key = "identity"});
    for (EpisodeRecord& r : part.records) {
      const int64_t k = r.episode;
      Check(by_episode.emplace(k, std::move(r)).second,
            "episode " + std::to_string(k) + " is in more than one part", {.file = path});
    }
  }
  std::vector<EpisodeRecord> records;
  for (int64_t k : episodes) {
    auto it = by_episode.find(k);
    Check(it != by_episode.end(), "no part holds episode " + std::to_string(k), {.file = dir});
    records.push_back(std::move(it->second));
  }
  return records;
}

}  // namespace wm::evaluate

// index.json of a token dataset: JSON conversion, validation and assembly from part files.
#include <cstdio>
#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/json_int.h"
#include "core/provenance.h"
#include "core/tokens/token_dataset.h"
#include "core/tokens/token_format.h"

namespace wm::tokens {
namespace {
using nlohmann::json;
namespace fs = std::filesystem;

json TokenizerToJson(const TokenizerInfo& t) {
  json j = {{"checkpoint_sha256", t.checkpoint_sha256},
            {"config_hash", t.config_hash},
            {"num_codes", t.num_codes},
            {"grid", {t.grid_h, t.grid_w}},
            {"image_size", t.image_size},
            {"image_key", t.image_key}};
  if (t.levels > 1) j["levels"] = t.levels;  // one level keeps the bytes (and run keys) it had
  return j;
}

TokenizerInfo TokenizerFromJson(const json& j) {
  TokenizerInfo t;
  t.checkpoint_sha256 = j.at("checkpoint_sha256").get<std::string>();
  t.config_hash = j.at("config_hash").get<std::string>();
  t.num_codes = JsonInt<int64_t>(j.at("num_codes"));
  t.grid_h = JsonInt<int>(j.at("grid").at(0));
  t.grid_w = JsonInt<int>(j.at("grid").at(1));
  t.image_size = JsonInt<int>(j.at("image_size"));
  t.image_key = j.at("image_key").get<std::string>();
  if (j.contains("levels")) t.levels = JsonInt<int>(j["levels"]);
  return t;
}

json PartToJson(const PartInfo& p) {
  json sections = json::object();
  for (const auto& [name, s] : p.sections) {
    sections[name] = {
        {"offset", s.offset}, {"dtype", s.dtype}, {"shape", s.shape}, {"crc32c", s.crc32c}};
  }
  return {{"file", p.file},
          {"bytes", p.bytes},
          {"sha256", p.sha256},
          {"num_episodes", p.num_episodes},
          {"num_frames", p.num_frames},
          {"sections", sections}};
}

PartInfo PartFromJson(const json& j) {
  PartInfo p;
  p.file = j.at("file").get<std::string>();
  p.bytes = JsonInt<uint64_t>(j.at("bytes"));
  p.sha256 = j.at("sha256").get<std::string>();
  p.num_episodes = JsonInt<int64_t>(j.at("num_episodes"));
  p.num_frames = JsonInt<int64_t>(j.at("num_frames"));
  for (const auto& [name, s] : j.at("sections").items()) {
    p.sections[name] = {JsonInt<uint64_t>(s.at("offset")), s.at("dtype").get<std::string>(),
                        JsonInts<int64_t>(s.at("shape")), JsonInt<uint32_t>(s.at("crc32c"))};
  }
  return p;
}

json EpisodeToJson(const TokenEpisode& e) {
  json j = {{"part", e.part},
            {"frame_offset", e.frame_offset},
            {"num_frames", e.num_frames},
            {"source_episode", e.source_episode},
            {"episode_key", e.episode_key},
            {"policy_id", e.policy_id},
            {"language_instruction", e.language_instruction},
            {"episode_seed", nullptr}};
  if (e.episode_seed) j["episode_seed"] = *e.episode_seed;
  return j;
}

TokenEpisode EpisodeFromJson(const json& j) {
  TokenEpisode e;
  e.part = JsonInt<int>(j.at("part"));
  e.frame_offset = JsonInt<int64_t>(j.at("frame_offset"));
  e.num_frames = JsonInt<int64_t>(j.at("num_frames"));
  e.source_episode = JsonInt<int64_t>(j.at("source_episode"));
  e.episode_key = j.at("episode_key").get<std::string>();
  e.policy_id = j.at("policy_id").get<std::string>();
  e.language_instruction = j.at("language_instruction").get<std::string>();
  if (!j.at("episode_seed").is_null()) e.episode_seed = JsonInt<int64_t>(j["episode_seed"]);
  return e;
}

// The oldest version that can say what `x` holds, so a reader never misreads a newer dataset.
uint32_t IndexVersion(const TokenIndex& x) {
  if (x.tokenizer.levels > 1) return kTokenIndexVersionLevels;
  if (!shard::IsCanonicalAction(x.action_dim, x.action_space)) return kTokenIndexVersionAnyAction;
  return kTokenFormatVersion;
}

json ReadJsonFile(const std::string& path) {
  json j = json::parse(ReadFile(path), nullptr, /*allow_exceptions=*/false);
  Check(!j.is_discarded(), "not valid JSON", {.file = path});
  return j;
}

}  // namespace

std::string PartFileName(int part) {
  char name[32];
  std::snprintf(name, sizeof(name), "part-%05d.wmtok", part);
  return name;
}

std::string PartJsonName(int part) {
  char name[32];
  std::snprintf(name, sizeof(name), "part-%05d.json", part);
  return name;
}

size_t DtypeSize(const std::string& dtype) {
  if (dtype == "<u2") return 2;
  if (dtype == "<u4" || dtype == "<f4") return 4;
  if (dtype == "|u1") return 1;
  throw Error("unsupported dtype '" + dtype + "'");
}

std::optional<uint64_t> SectionByteSize(const std::string& dtype,
                                        const std::vector<int64_t>& shape) {
  uint64_t bytes = DtypeSize(dtype);
  for (int64_t d : shape) {
    if (d < 0 || __builtin_mul_overflow(bytes, static_cast<uint64_t>(d), &bytes)) return {};
  }
  return bytes;
}

std::vector<int64_t> StepSectionShape(const StepSectionSpec& spec, int64_t frames,
                                      int64_t action_dim) {
  if (spec.per_frame == 0) return {frames, action_dim};
  if (spec.per_frame == 1) return {frames};
  return {frames, spec.per_frame};
}

std::vector<int64_t> TokenSectionShape(const TokenizerInfo& t, int64_t frames) {
  if (t.levels == 1) return {frames, t.grid_h, t.grid_w};
  return {frames, t.levels, t.grid_h, t.grid_w};
}

std::string RunKey(const TokenIndex& base, int num_parts) {
  return ConfigHash({{"tokenizer", TokenizerToJson(base.tokenizer)},
                     {"source", base.source},
                     {"num_parts", num_parts}});
}

std::pair<int64_t, int64_t> PartEpisodeRange(int64_t num_episodes, int part, int num_parts) {
  return {num_episodes * part / num_parts, num_episodes * (part + 1) / num_parts};
}

json TokenIndexToJson(const TokenIndex& x) {
  json parts = json::array(), episodes = json::array();
  for (const auto& p : x.parts) parts.push_back(PartToJson(p));
  for (const auto& e : x.episodes) episodes.push_back(EpisodeToJson(e));
  const uint32_t version = IndexVersion(x);
  json j = {{"format", kTokenFormatName},
            {"format_version", version},
            {"dataset", x.dataset},
            {"split", x.split},
            {"tokenizer", TokenizerToJson(x.tokenizer)},
            {"token_dtype", x.token_dtype},
            {"source", x.source},
            {"action_stats", shard::StatsToJson(x.action_stats)},
            {"num_parts", x.num_parts},
            {"parts", parts},
            {"num_episodes", x.episodes.size()},
            {"num_frames", x.num_frames},
            {"episodes", episodes},
            {"provenance", x.provenance}};
  if (version != kTokenFormatVersion) {  // version 1 keeps its bytes: the keys are implied there
    j["action_dim"] = x.action_dim;
    j["action_space"] = x.action_space;
  }
  return j;
}

TokenIndex TokenIndexFromJson(const json& j, const std::string& file) {
  Check(j.is_object() && j.contains("format") && j["format"] == kTokenFormatName,
        std::string("not a wmkit token index (format must be \"") + kTokenFormatName + "\")",
        {.file = file, .key = "format"});
  const json version_json = j.contains("format_version") ? j["format_version"] : json();
  const uint32_t version =
      version_json.is_number_unsigned() ? version_json.get<uint32_t>() : uint32_t{0};
  Check(version >= kTokenFormatVersion && version <= kTokenIndexVersionLevels,
        "unknown format_version " + version_json.dump() + " (this build reads versions " +
            std::to_string(kTokenFormatVersion) + " to " +
            std::to_string(kTokenIndexVersionLevels) + ")",
        {.file = file, .key = "format_version"});
  const bool any_action = version != kTokenFormatVersion;
  TokenIndex x;
  std::string key;
  try {
    if (any_action) {
      key = "action_dim", x.action_dim = JsonInt<int64_t>(j.at(key));
      key = "action_space", x.action_space = j.at(key).get<std::string>();
    }
    key = "dataset", x.dataset = j.at(key).get<std::string>();
    key = "split", x.split = j.at(key).get<std::string>();
    key = "tokenizer", x.tokenizer = TokenizerFromJson(j.at(key));
    key = "token_dtype", x.token_dtype = j.at(key).get<std::string>();
    key = "source", x.source = j.at(key);
    key = "action_stats", x.action_stats = shard::StatsFromJson(j.at(key));
    key = "num_parts", x.num_parts = JsonInt<int>(j.at(key));
    key = "parts";
    for (const auto& p : j.at(key)) x.parts.push_back(PartFromJson(p));
    key = "episodes";
    for (const auto& e : j.at(key)) x.episodes.push_back(EpisodeFromJson(e));
    key = "num_frames", x.num_frames = JsonInt<int64_t>(j.at(key));
    key = "provenance", x.provenance = j.at(key);
  } catch (const json::exception& e) {
    throw Error(std::string("malformed token index: ") + e.what(), {.file = file, .key = key});
  }
  const bool residual = version == kTokenIndexVersionLevels;
  Check(residual ? x.tokenizer.levels >= 2 && x.tokenizer.levels <= kMaxTokenLevels
                 : !j.at("tokenizer").contains("levels"),
        residual
            ? "format_version 3 needs tokenizer.levels in [2, " + std::to_string(kMaxTokenLevels) +
                  "], got " + std::to_string(x.tokenizer.levels)
            : "tokenizer.levels is only written by format_version 3",
        {.file = file, .key = "tokenizer.levels"});
  Check(x.action_dim >= 1 && x.action_dim <= kMaxActionDim,
        "action_dim must be in [1, " + std::to_string(kMaxActionDim) + "], got " +
            std::to_string(x.action_dim),
        {.file = file, .key = "action_dim"});
  Check(shard::IsKnownActionSpace(x.action_space),
        "action_space must be eef_delta, joint_position or other, got '" + x.action_space + "'",
        {.file = file, .key = "action_space"});
  Check(static_cast<int64_t>(x.action_stats.mean.size()) == x.action_dim,
        "action_stats has " + std::to_string(x.action_stats.mean.size()) +
            " values per vector, action_dim is " + std::to_string(x.action_dim),
        {.file = file, .key = "action_stats"});
  Check(x.token_dtype == "uint16" || x.token_dtype == "uint32",
        "token_dtype must be uint16 or uint32", {.file = file, .key = "token_dtype"});
  Check(static_cast<int>(x.parts.size()) == x.num_parts, "parts has not num_parts entries",
        {.file = file, .key = "parts"});
  int64_t frames = 0;
  bool summed = true;  // false when the sum overflows, which only damage can cause
  for (const auto& e : x.episodes) {
    Check(e.part >= 0 && e.part < x.num_parts, "episode refers to a missing part",
          {.file = file, .key = "episodes"});
    summed = summed && !__builtin_add_overflow(frames, e.num_frames, &frames);
  }
  Check(summed && frames == x.num_frames, "num_frames disagrees with the sum over episodes",
        {.file = file, .key = "num_frames"});
  return x;
}

bool AssembleIndexIfComplete(const std::string& dir, int num_parts, TokenIndex base) {
  std::vector<json> part_jsons;
  for (int i = 0; i < num_parts; ++i) {
    std::string path = (fs::path(dir) / PartJsonName(i)).string();
    if (!fs::exists(path)) return false;
    part_jsons.push_back(ReadJsonFile(path));
  }
  base.num_parts = num_parts;
  base.token_dtype = base.tokenizer.num_codes > 65536 ? "uint32" : "uint16";
  base.parts.clear();
  base.episodes.clear();
  base.num_frames = 0;
  for (int i = 0; i < num_parts; ++i) {
    const json& pj = part_jsons[i];
    std::string path = (fs::path(dir) / PartJsonName(i)).string();
    // Parts of an earlier run with another tokenizer or sharding must not be mixed in.
    Check(pj.value("num_parts", 0) == num_parts,
          "written for " + std::to_string(pj.value("num_parts", 0)) + " parts, not " +
              std::to_string(num_parts) + " (remove stale part files)",
          {.file = path, .key = "num_parts"});
    Check(pj.value("tokenizer_sha256", "") == base.tokenizer.checkpoint_sha256,
          "written by another tokenizer checkpoint (remove stale part files)",
          {.file = path, .key = "tokenizer_sha256"});
    Check(pj.value("run_key", "") == RunKey(base, num_parts),
          "written for other source data or options (remove stale part files)",
          {.file = path, .key = "run_key"});
    Check(pj.value("part_index", -1) == i, "part_index differs from the file name",
          {.file = path, .key = "part_index"});
    try {
      base.parts.push_back(PartFromJson(pj.at("part")));
      for (const auto& e : pj.at("episodes")) base.episodes.push_back(EpisodeFromJson(e));
    } catch (const json::exception& e) {
      throw Error(std::string("malformed part file: ") + e.what(), {.file = path});
    }
  }
  for (const auto& e : base.episodes) base.num_frames += e.num_frames;
  WriteFileAtomically((fs::path(dir) / kTokenIndexFileName).string(),
                      TokenIndexToJson(base).dump(2) + "\n");
  return true;
}

}  // namespace wm::tokens

#include "core/shard/episode_codec.h"

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/json_int.h"
#include "core/shard/shard_format.h"
#include "core/zstd_codec.h"

namespace wm::shard {
namespace {
using nlohmann::json;

template <typename T>
const char* DtypeName();
template <>
const char* DtypeName<float>() {
  return "float32";
}
template <>
const char* DtypeName<uint8_t>() {
  return "uint8";
}

template <typename T>
json AppendArray(std::string& body, const std::string& name, const std::vector<T>& values,
                 int64_t rows, int64_t cols, int level) {
  std::string_view raw(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
  std::string packed = ZstdCompress(raw, level);
  json shape = cols > 0 ? json::array({rows, cols}) : json::array({rows});
  json s = {{"name", name},
            {"kind", "array"},
            {"dtype", DtypeName<T>()},
            {"shape", shape},
            {"codec", "zstd"},
            {"offset", body.size()},
            {"length", packed.size()},
            {"raw_length", raw.size()}};
  body += packed;
  return s;
}

json AppendBlobs(std::string& body, const std::string& name, const EncodedFrames& frames) {
  size_t start = body.size();
  for (const auto& f : frames.frames) PutU64(body, f.size());
  for (const auto& f : frames.frames) body += f;
  return {{"name", name},
          {"kind", "blobs"},
          {"encoding", frames.encoding},
          {"dtype", frames.dtype},
          {"shape", {frames.height, frames.width, frames.channels}},
          {"count", frames.frames.size()},
          {"offset", start},
          {"length", body.size() - start}};
}

std::string_view SectionBytes(const json& s, std::string_view body) {
  uint64_t off = JsonInt<uint64_t>(s.at("offset")), len = JsonInt<uint64_t>(s.at("length"));
  Check(off <= body.size() && len <= body.size() - off,
        "section runs past the record body (offset " + std::to_string(off) + " + length " +
            std::to_string(len) + " > body " + std::to_string(body.size()) + ")");
  return body.substr(off, len);
}

template <typename T>
std::vector<T> ReadArray(const json& s, std::string_view body, int64_t rows, int64_t cols) {
  Check(s.at("kind") == "array" && s.at("dtype") == DtypeName<T>(),
        std::string("expected an array section of dtype ") + DtypeName<T>());
  uint64_t expected = 0;  // rows x cols x sizeof(T); rows is num_steps, which damage can set
  Check(rows >= 0 && !__builtin_mul_overflow(static_cast<uint64_t>(rows),
                                             std::max<int64_t>(cols, 1) * sizeof(T), &expected),
        "num_steps " + std::to_string(rows) + " gives no valid array size");
  Check(JsonInt<uint64_t>(s.at("raw_length")) == expected,
        "raw_length " + s.at("raw_length").dump() + " != " + std::to_string(expected));
  std::string_view bytes = SectionBytes(s, body);
  std::string raw = s.at("codec") == "zstd" ? ZstdDecompress(bytes, expected) : std::string(bytes);
  Check(raw.size() == expected, "array holds " + std::to_string(raw.size()) + " bytes, expected " +
                                    std::to_string(expected));
  std::vector<T> out(expected / sizeof(T));
  std::memcpy(out.data(), raw.data(), raw.size());
  return out;
}

// The action section's row width D (shape [T, D]), bounded so damage cannot ask for anything.
int64_t ActionWidth(const json& s) {
  const auto shape = JsonInts<int64_t>(s.at("shape"));
  Check(shape.size() == 2 && shape[1] >= 1 && shape[1] <= kMaxActionDim,
        "action shape must be [T, D] with 1 <= D <= " + std::to_string(kMaxActionDim) + ", got " +
            s.at("shape").dump());
  return shape[1];
}

EncodedFrames ReadBlobs(const json& s, std::string_view body, int64_t count) {
  Check(s.at("kind") == "blobs", "expected a blobs section");
  Check(JsonInt<int64_t>(s.at("count")) == count,
        "blob count " + s.at("count").dump() + " != num_steps " + std::to_string(count));
  std::string_view bytes = SectionBytes(s, body);
  Check(count >= 0 && static_cast<uint64_t>(count) <= bytes.size() / 8,
        "blob length table truncated");
  EncodedFrames f;
  f.encoding = s.at("encoding").get<std::string>();
  f.dtype = s.at("dtype").get<std::string>();
  auto shape = JsonInts<int>(s.at("shape"));
  Check(shape.size() == 3, "blob shape must be [H, W, C]");
  f.height = shape[0], f.width = shape[1], f.channels = shape[2];
  size_t pos = 8 * static_cast<size_t>(count);
  const auto* lengths = reinterpret_cast<const uint8_t*>(bytes.data());
  for (int64_t i = 0; i < count; ++i) {
    uint64_t len = GetU64(lengths + 8 * i);
    Check(len <= bytes.size() - pos, "blob " + std::to_string(i) + " runs past its section");
    f.frames.emplace_back(bytes.substr(pos, len));
    pos += len;
  }
  Check(pos == bytes.size(), "blob section has trailing bytes");
  return f;
}

}  // namespace

EncodedRecord EncodeEpisode(const Episode& e, int level) {
  const int64_t t = e.num_steps;
  std::string body;
  json sections = json::array();
  sections.push_back(AppendArray(body, "action", e.actions, t, e.action_dim, level));
  sections.push_back(AppendArray(body, "reward", e.rewards, t, 0, level));
  sections.push_back(AppendArray(body, "discount", e.discounts, t, 0, level));
  sections.push_back(AppendArray(body, "is_first", e.is_first, t, 0, level));
  sections.push_back(AppendArray(body, "is_last", e.is_last, t, 0, level));
  sections.push_back(AppendArray(body, "is_terminal", e.is_terminal, t, 0, level));
  for (const auto& [name, frames] : e.images) sections.push_back(AppendBlobs(body, name, frames));
  json meta = {{"episode_key", e.episode_key},
               {"source", {{"file", e.source_file}, {"record", e.source_record}}},
               {"num_steps", t},
               {"language_instruction", e.language_instruction},
               {"policy_id", e.policy_id},
               {"episode_seed", e.episode_seed ? json(*e.episode_seed) : json(nullptr)},
               {"sections", sections}};
  // Only written when not the canonical space, so canonical records keep their version-1 bytes.
  if (e.action_space != "eef_delta") meta["action_space"] = e.action_space;
  return {meta.dump(), std::move(body)};
}

Episode DecodeEpisode(std::string_view meta_text, std::string_view body, bool with_images) {
  json meta = json::parse(meta_text, nullptr, /*allow_exceptions=*/false);
  Check(meta.is_object(), "episode meta is not a JSON object");
  Episode e;
  std::string current_key = "meta";
  try {
    e.episode_key = meta.at("episode_key").get<std::string>();
    e.source_file = meta.at("source").at("file").get<std::string>();
    e.source_record = JsonInt<int64_t>(meta.at("source").at("record"));
    e.num_steps = JsonInt<int64_t>(meta.at("num_steps"));
    e.language_instruction = meta.at("language_instruction").get<std::string>();
    e.policy_id = meta.at("policy_id").get<std::string>();
    if (!meta.at("episode_seed").is_null()) {
      e.episode_seed = JsonInt<int64_t>(meta["episode_seed"]);
    }
    e.action_space = meta.value("action_space", std::string("eef_delta"));
    const int64_t t = e.num_steps;
    for (const auto& s : meta.at("sections")) {
      current_key = s.at("name").get<std::string>();
      if (current_key == "action") {
        e.action_dim = ActionWidth(s);
        e.actions = ReadArray<float>(s, body, t, e.action_dim);
      } else if (current_key == "reward")
        e.rewards = ReadArray<float>(s, body, t, 0);
      else if (current_key == "discount")
        e.discounts = ReadArray<float>(s, body, t, 0);
      else if (current_key == "is_first")
        e.is_first = ReadArray<uint8_t>(s, body, t, 0);
      else if (current_key == "is_last")
        e.is_last = ReadArray<uint8_t>(s, body, t, 0);
      else if (current_key == "is_terminal")
        e.is_terminal = ReadArray<uint8_t>(s, body, t, 0);
      else if (s.at("kind") == "blobs" && with_images)
        e.images[current_key] = ReadBlobs(s, body, t);
    }
  } catch (const json::exception& ex) {
    throw Error(std::string("malformed episode meta: ") + ex.what(), {.key = current_key});
  } catch (const Error& ex) {
    throw ex.WithKey(current_key);
  }
  const auto t = static_cast<size_t>(e.num_steps);
  Check(e.actions.size() == t * static_cast<size_t>(e.action_dim) && e.rewards.size() == t &&
            e.discounts.size() == t && e.is_first.size() == t && e.is_last.size() == t &&
            e.is_terminal.size() == t,
        "record lacks one of the sections action, reward, discount, is_first, is_last, "
        "is_terminal");
  Check(!with_images || e.images.count("image") == 1, "record has no image section");
  return e;
}

}  // namespace wm::shard

#pragma once
// Token datasets: pre-tokenized episodes (docs/token-format.md, schemas/token-index.schema.json).
//
//   TOKENS_DIR/index.json          what the dataset holds: tokenizer, source, parts, episodes
//   TOKENS_DIR/part-NNNNN.wmtok    one part per encode job: a 64-byte header, then raw
//                                  little-endian arrays (tokens [F, (levels,) h, w], actions [F,
//                                  D], ...) at 64-byte aligned offsets that numpy can memmap
//   TOKENS_DIR/part-NNNNN.json     the part's index entry and episodes (assembled into index.json)
//
// Readers map the part files and verify each section's CRC32C on open.
#include <cstdint>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/episode.h"
#include "core/shard/dataset_index.h"

namespace wm::tokens {

inline constexpr const char* kTokenFormatName = "wmkit-tokens";
// Part files, and index.json of datasets with the canonical 7-dim eef_delta action (whose bytes
// stay those of the first version).
inline constexpr uint32_t kTokenFormatVersion = 1;
// index.json of any other action: it records action_dim and action_space, so that a version-1
// reader (which assumes 7 end-effector deltas) refuses it.
inline constexpr uint32_t kTokenIndexVersionAnyAction = 2;
// index.json of a residual tokenizer's codes (tokenizer.levels > 1): it always records the
// action's width and space, and a reader of versions 1-2 (one code per cell) refuses it.
inline constexpr uint32_t kTokenIndexVersionLevels = 3;
inline constexpr int kMaxTokenLevels = 8;  // as the tokenizer's model.levels

// Which tokenizer produced the tokens; the dynamics model checks it matches its own.
struct TokenizerInfo {
  std::string checkpoint_sha256;  // of the tokenizer's checkpoint.wmt
  std::string config_hash;        // of the tokenizer config
  int64_t num_codes = 0;
  int grid_h = 0, grid_w = 0;  // cells per frame = grid_h * grid_w
  int levels = 1;              // codes per cell (residual VQ)
  int image_size = 0;          // frames were resized to image_size x image_size
  std::string image_key = "image";

  int64_t tokens_per_frame() const { return int64_t{levels} * grid_h * grid_w; }
};

// The tokens section's shape in a part of `frames` frames: [F, h, w], or [F, levels, h, w].
std::vector<int64_t> TokenSectionShape(const TokenizerInfo& t, int64_t frames);

// One episode's place and carried-over metadata.
struct TokenEpisode {
  int part = 0;                // which part file holds it
  int64_t frame_offset = 0;    // first frame within that part
  int64_t num_frames = 0;      // = the source episode's num_steps
  int64_t source_episode = 0;  // index of the episode in the source shard dataset
  std::string episode_key, policy_id, language_instruction;
  std::optional<int64_t> episode_seed;
};

// One raw array inside a part file.
struct Section {
  uint64_t offset = 0;         // bytes from the start of the file, a multiple of 64
  std::string dtype;           // numpy spelling: "<u2", "<u4", "<f4", "|u1"
  std::vector<int64_t> shape;  // C order
  uint32_t crc32c = 0;         // of the section's bytes
};

struct PartInfo {
  std::string file;  // "part-00003.wmtok"
  uint64_t bytes = 0;
  std::string sha256;
  int64_t num_episodes = 0, num_frames = 0;
  // "tokens" [F, h, w] (one level) or [F, levels, h, w], "actions" [F, D], "rewards" [F],
  // "discounts" [F], "is_first" [F], "is_last" [F], "is_terminal" [F].
  std::map<std::string, Section> sections;
};

struct TokenIndex {
  std::string dataset, split;
  TokenizerInfo tokenizer;
  std::string token_dtype = "uint16";                // "uint32" only when num_codes > 65536
  nlohmann::json source = nlohmann::json::object();  // source shard dataset: name, hashes
  shard::ActionStats action_stats;                   // copied from the source index (D each)
  // The action's width D and space, copied from the source shard index (features.action);
  // version-1 indexes, which predate other widths, read as 7 / "eef_delta".
  int64_t action_dim = kActionDim;
  std::string action_space = "eef_delta";
  int num_parts = 1;
  std::vector<PartInfo> parts;
  std::vector<TokenEpisode> episodes;  // in source order
  int64_t num_frames = 0;
  nlohmann::json provenance = nlohmann::json::object();
};

nlohmann::json TokenIndexToJson(const TokenIndex& index);
TokenIndex TokenIndexFromJson(const nlohmann::json& j, const std::string& file);

// "part-00003.wmtok"
std::string PartFileName(int part);

// The source episodes part `part` of `num_parts` encodes: the contiguous range
// [first, last) of [0, num_episodes).
std::pair<int64_t, int64_t> PartEpisodeRange(int64_t num_episodes, int part, int num_parts);

// Streams one part: tokens are appended to a temp file as they come (bounded memory); the
// small per-step arrays are kept and written at Finish(), then the file is fsynced and renamed.
class TokenPartWriter {
 public:
  // `base`: the dataset's tokenizer and source (as for AssembleIndexIfComplete); its RunKey is
  // recorded so parts of different runs are never assembled together. Creates `dir`.
  TokenPartWriter(std::string dir, int part, int num_parts, const TokenIndex& base);
  ~TokenPartWriter();  // without Finish() the temp file is removed

  // tokens: [num_frames, levels, grid_h, grid_w] codes; per-step arrays as in wm::Episode.
  void AddEpisode(const TokenEpisode& meta, const std::vector<uint32_t>& tokens,
                  const Episode& steps);
  PartInfo Finish();  // atomic; also writes part-NNNNN.json

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// Identifies one encode run: hash of the tokenizer, the source data and the part count.
std::string RunKey(const TokenIndex& base, int num_parts);

// Writes index.json (atomically) from the part-*.json files when all `num_parts` exist;
// returns false (and writes nothing) while some are missing. `base` supplies dataset, split,
// tokenizer, source, action stats and provenance; parts and episodes come from the part files.
bool AssembleIndexIfComplete(const std::string& dir, int num_parts, TokenIndex base);

// Read side: maps every part; verifies each section's CRC32C on open (throws wm::Error naming
// the file and section on mismatch, and on any structural problem).
class TokenDataset {
 public:
  explicit TokenDataset(const std::string& dir);
  ~TokenDataset();

  const TokenIndex& index() const;
  const std::string& dir() const;
  int64_t num_episodes() const;
  const TokenEpisode& episode(int64_t k) const;
  int64_t tokens_per_frame() const;  // levels * grid_h * grid_w

  // Copies frames [first, first + count) of episode k: tokens to out[count * tokens_per_frame()]
  // (each frame [levels, h, w]; either token dtype), widening to int64 for torch.
  void CopyTokens(int64_t k, int64_t first, int64_t count, int64_t* out) const;
  int64_t action_dim() const;  // D, values per action (index().action_dim)
  // Per-step arrays of episode k, [num_frames(, D)], pointing into the mapping.
  const float* actions(int64_t k) const;
  const float* rewards(int64_t k) const;
  const float* discounts(int64_t k) const;
  const uint8_t* is_first(int64_t k) const;
  const uint8_t* is_last(int64_t k) const;
  const uint8_t* is_terminal(int64_t k) const;

 private:
  const uint8_t* StepBytes(int64_t k, const char* section, size_t frame_bytes) const;
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace wm::tokens

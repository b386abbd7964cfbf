#pragma once
// Byte layout constants of shard format v1. docs/shard-format.md is the specification; keep
// the two in step.
#include <cstdint>
#include <cstring>
#include <string>

namespace wm::shard {

// Shard files, and index.json of datasets with the canonical 7-dim eef_delta action.
inline constexpr uint32_t kFormatVersion = 1;
// index.json of a dataset whose action has another width or space (features.action.dim/space):
// readers of version 1 assume 7 Δ-pose dimensions, so such an index must stop them.
inline constexpr uint32_t kIndexVersionAnyAction = 2;
inline constexpr char kFileMagic[8] = {'W', 'M', 'K', 'S', 'H', 'A', 'R', 'D'};
inline constexpr char kTrailerMagic[8] = {'W', 'M', 'K', 'S', 'H', 'E', 'N', 'D'};
inline constexpr char kRecordMagic[4] = {'W', 'M', 'E', 'R'};
inline constexpr size_t kFileHeaderSize = 16;
inline constexpr size_t kRecordHeaderSize = 24;
inline constexpr size_t kIndexEntrySize = 24;
inline constexpr size_t kTrailerSize = 40;
inline constexpr const char* kIndexFileName = "index.json";
inline constexpr const char* kFormatName = "wmkit-shard";

// "shard-00012.wms"
std::string ShardFileName(int number);

// Little-endian field access; the format is little-endian on every host.
inline void PutU32(std::string& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}
inline void PutU64(std::string& out, uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}
inline uint32_t GetU32(const uint8_t* p) {
  uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}
inline uint64_t GetU64(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

struct IndexEntry {
  uint64_t offset = 0;
  uint64_t length = 0;
  uint32_t num_steps = 0;
};

}  // namespace wm::shard

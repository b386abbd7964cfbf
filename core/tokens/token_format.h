#pragma once
// Byte layout of a token part file (docs/token-format.md is the specification).
//   [0, 64)   header: "WMTOKEN1", u32 version, u32 token bytes (2|4), u32 grid_h, u32 grid_w,
//             u32 levels (0: one level), zeros, u32 CRC32C of bytes [0, 60) at 60
//   then each section of TokenIndex::parts[i].sections at a 64-byte aligned offset, zero padded.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace wm::tokens {

inline constexpr char kPartMagic[8] = {'W', 'M', 'T', 'O', 'K', 'E', 'N', '1'};
inline constexpr size_t kPartHeaderSize = 64;
inline constexpr size_t kSectionAlignment = 64;
inline constexpr const char* kTokenIndexFileName = "index.json";

// The per-step sections, in file order after "tokens": name, numpy dtype, values per frame
// (0: the dataset's action width D, always a second axis).
struct StepSectionSpec {
  const char* name;
  const char* dtype;
  int per_frame;
};
inline constexpr StepSectionSpec kStepSections[] = {
    {"actions", "<f4", 0},  {"rewards", "<f4", 1}, {"discounts", "<f4", 1},
    {"is_first", "|u1", 1}, {"is_last", "|u1", 1}, {"is_terminal", "|u1", 1}};

// A step section's shape in a part of `frames` frames: [F] or [F, D].
std::vector<int64_t> StepSectionShape(const StepSectionSpec& spec, int64_t frames,
                                      int64_t action_dim);

// "part-00003.json": the part's entry and episodes, merged into index.json.
std::string PartJsonName(int part);

// Bytes per element of a numpy dtype string used here ("<u2" -> 2).
size_t DtypeSize(const std::string& dtype);

// Bytes of a section of `dtype` and `shape`; nullopt for a negative dimension or a product that
// overflows, which only a damaged index.json can give (it must not wrap into a small number).
std::optional<uint64_t> SectionByteSize(const std::string& dtype,
                                        const std::vector<int64_t>& shape);

}  // namespace wm::tokens

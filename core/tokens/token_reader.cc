// TokenDataset: maps a token dataset's part files and checks every byte against its CRC.
#include <algorithm>
#include <cstring>
#include <filesystem>

#include "core/atomic_file.h"
#include "core/crc32c.h"
#include "core/error.h"
#include "core/mapped_file.h"
#include "core/shard/shard_format.h"
#include "core/tokens/token_dataset.h"
#include "core/tokens/token_format.h"

namespace wm::tokens {
namespace {
namespace fs = std::filesystem;

void CheckHeader(const MappedFile& f, size_t token_bytes, const TokenizerInfo& t) {
  const ErrorContext at{.file = f.path(), .key = "header"};
  Check(f.size() >= kPartHeaderSize && std::memcmp(f.data(), kPartMagic, 8) == 0,
        "not a wmkit token part (bad magic)", at);
  const uint8_t* h = f.data();
  Check(shard::GetU32(h + 60) == Crc32c(h, 60), "header checksum mismatch (corrupt file)", at);
  Check(shard::GetU32(h + 8) == kTokenFormatVersion, "unknown part format version", at);
  const uint32_t levels = std::max<uint32_t>(shard::GetU32(h + 24), 1);  // 0: written before levels
  Check(shard::GetU32(h + 12) == token_bytes && shard::GetU32(h + 16) == uint32_t(t.grid_h) &&
            shard::GetU32(h + 20) == uint32_t(t.grid_w) && levels == uint32_t(t.levels),
        "token width, grid or levels differ from index.json", at);
}

// Checks a section's place, size and CRC32C; returns its first byte.
const uint8_t* CheckSection(const MappedFile& f, const PartInfo& part, const std::string& name,
                            const std::vector<int64_t>& shape, const std::string& dtype) {
  const ErrorContext at{.file = f.path(), .key = name};
  auto it = part.sections.find(name);
  Check(it != part.sections.end(), "section missing from index.json", at);
  const Section& s = it->second;
  Check(s.shape == shape && s.dtype == dtype, "section shape or dtype differs from expected", at);
  const std::optional<uint64_t> size = SectionByteSize(dtype, shape);
  Check(size.has_value(), "section shape gives no valid size", at);
  const uint64_t bytes = *size;
  Check(s.offset % kSectionAlignment == 0 && s.offset >= kPartHeaderSize && s.offset <= f.size() &&
            bytes <= f.size() - s.offset,
        "section lies outside the file (truncated?)", at);
  Check(Crc32c(f.data() + s.offset, bytes) == s.crc32c, "section checksum mismatch (corrupt file)",
        at);
  return f.data() + s.offset;
}

}  // namespace

struct TokenDataset::State {
  std::string dir;
  TokenIndex index;
  std::vector<std::unique_ptr<MappedFile>> files;
  struct PartArrays {
    const uint8_t* tokens = nullptr;
    std::map<std::string, const uint8_t*> steps;
  };
  std::vector<PartArrays> parts;
  size_t token_bytes = 2;
};

TokenDataset::TokenDataset(const std::string& dir) : state_(std::make_unique<State>()) {
  State& s = *state_;
  s.dir = dir;
  std::string path = (fs::path(dir) / kTokenIndexFileName).string();
  Check(fs::exists(path),
        "not a wmkit token dataset: index.json is missing (an unfinished or sharded "
        "wm-tokenize encode? every part must be written before index.json appears)",
        {.file = path});
  auto j = nlohmann::json::parse(ReadFile(path), nullptr, /*allow_exceptions=*/false);
  Check(!j.is_discarded(), "index.json is not valid JSON", {.file = path});
  s.index = TokenIndexFromJson(j, path);
  s.token_bytes = s.index.token_dtype == "uint16" ? 2 : 4;
  const TokenizerInfo& t = s.index.tokenizer;
  for (const PartInfo& part : s.index.parts) {
    std::string file = (fs::path(dir) / part.file).string();
    Check(part.file.find('/') == std::string::npos, "part file must be a plain name",
          {.file = path, .key = "parts"});
    auto mapped = std::make_unique<MappedFile>(file);
    Check(mapped->size() == part.bytes,
          "file has " + std::to_string(mapped->size()) + " bytes, index.json says " +
              std::to_string(part.bytes),
          {.file = file});
    CheckHeader(*mapped, s.token_bytes, t);
    State::PartArrays arrays;
    arrays.tokens = CheckSection(*mapped, part, "tokens", TokenSectionShape(t, part.num_frames),
                                 s.token_bytes == 2 ? "<u2" : "<u4");
    for (const StepSectionSpec& spec : kStepSections) {
      arrays.steps[spec.name] =
          CheckSection(*mapped, part, spec.name,
                       StepSectionShape(spec, part.num_frames, s.index.action_dim), spec.dtype);
    }
    s.parts.push_back(arrays);
    s.files.push_back(std::move(mapped));
  }
  for (size_t k = 0; k < s.index.episodes.size(); ++k) {
    const TokenEpisode& e = s.index.episodes[k];
    const int64_t part_frames = s.index.parts[e.part].num_frames;  // >= 0: its sections fit
    Check(e.frame_offset >= 0 && e.num_frames > 0 && e.frame_offset <= part_frames &&
              e.num_frames <= part_frames - e.frame_offset,
          "episode frames lie outside its part",
          {.file = path, .record = int64_t(k), .record_label = "episode"});
  }
}

TokenDataset::~TokenDataset() = default;

const TokenIndex& TokenDataset::index() const { return state_->index; }
const std::string& TokenDataset::dir() const { return state_->dir; }
int64_t TokenDataset::num_episodes() const {
  return static_cast<int64_t>(state_->index.episodes.size());
}
const TokenEpisode& TokenDataset::episode(int64_t k) const {
  Check(k >= 0 && k < num_episodes(), "episode index out of range",
        {.file = state_->dir, .record = k, .record_label = "episode"});
  return state_->index.episodes[static_cast<size_t>(k)];
}
int64_t TokenDataset::tokens_per_frame() const {
  return state_->index.tokenizer.tokens_per_frame();
}

void TokenDataset::CopyTokens(int64_t k, int64_t first, int64_t count, int64_t* out) const {
  const TokenEpisode& e = episode(k);
  Check(first >= 0 && count >= 0 && first + count <= e.num_frames, "frame range out of range",
        {.file = state_->dir, .record = k, .record_label = "episode"});
  const int64_t n = count * tokens_per_frame();
  const uint8_t* p =
      state_->parts[e.part].tokens +
      static_cast<size_t>((e.frame_offset + first) * tokens_per_frame()) * state_->token_bytes;
  for (int64_t i = 0; i < n; ++i) {  // the files are little-endian; so is every supported host
    if (state_->token_bytes == 2) {
      uint16_t v;
      std::memcpy(&v, p + 2 * i, 2);
      out[i] = v;
    } else {
      uint32_t v;
      std::memcpy(&v, p + 4 * i, 4);
      out[i] = v;
    }
  }
}

const uint8_t* TokenDataset::StepBytes(int64_t k, const char* name, size_t frame_bytes) const {
  const TokenEpisode& e = episode(k);
  return state_->parts[e.part].steps.at(name) + static_cast<size_t>(e.frame_offset) * frame_bytes;
}

int64_t TokenDataset::action_dim() const { return state_->index.action_dim; }

const float* TokenDataset::actions(int64_t k) const {
  return reinterpret_cast<const float*>(
      StepBytes(k, "actions", static_cast<size_t>(action_dim()) * sizeof(float)));
}
const float* TokenDataset::rewards(int64_t k) const {
  return reinterpret_cast<const float*>(StepBytes(k, "rewards", sizeof(float)));
}
const float* TokenDataset::discounts(int64_t k) const {
  return reinterpret_cast<const float*>(StepBytes(k, "discounts", sizeof(float)));
}
const uint8_t* TokenDataset::is_first(int64_t k) const { return StepBytes(k, "is_first", 1); }
const uint8_t* TokenDataset::is_last(int64_t k) const { return StepBytes(k, "is_last", 1); }
const uint8_t* TokenDataset::is_terminal(int64_t k) const { return StepBytes(k, "is_terminal", 1); }

}  // namespace wm::tokens

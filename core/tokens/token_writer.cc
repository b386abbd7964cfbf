// TokenPartWriter: streams one token part file (tokens first, then the small per-step arrays).
#include <bit>
#include <filesystem>

#include "core/atomic_file.h"
#include "core/crc32c.h"
#include "core/error.h"
#include "core/sha256.h"
#include "core/shard/shard_format.h"
#include "core/tokens/token_dataset.h"
#include "core/tokens/token_format.h"

namespace wm::tokens {
namespace {
static_assert(std::endian::native == std::endian::little,
              "token part files are little-endian; this writer assumes a little-endian host");

std::string PartHeader(size_t token_bytes, const TokenizerInfo& t) {
  std::string h(kPartMagic, sizeof(kPartMagic));
  shard::PutU32(h, kTokenFormatVersion);
  shard::PutU32(h, static_cast<uint32_t>(token_bytes));
  shard::PutU32(h, static_cast<uint32_t>(t.grid_h));
  shard::PutU32(h, static_cast<uint32_t>(t.grid_w));
  shard::PutU32(h, t.levels > 1 ? static_cast<uint32_t>(t.levels) : 0);  // 0: one, as before
  h.resize(kPartHeaderSize - 4, '\0');
  shard::PutU32(h, Crc32c(h));
  return h;
}

}  // namespace

struct TokenPartWriter::State {
  std::string dir;
  int part = 0, num_parts = 1;
  std::string run_key;
  TokenizerInfo tokenizer;
  int64_t action_dim = kActionDim;
  size_t token_bytes = 2;
  AtomicFileWriter file;
  Sha256 sha;
  uint32_t token_crc = 0;
  int64_t frames = 0;
  std::vector<TokenEpisode> episodes;
  std::vector<float> actions, rewards, discounts;
  std::vector<uint8_t> is_first, is_last, is_terminal;
  bool finished = false;

  State(std::string d, int p, int n, std::string key, const TokenIndex& base)
      : dir(std::move(d)),
        part(p),
        num_parts(n),
        run_key(std::move(key)),
        tokenizer(base.tokenizer),
        action_dim(base.action_dim),
        token_bytes(base.tokenizer.num_codes > 65536 ? 4 : 2),
        file((std::filesystem::path(CreatedDir(dir)) / PartFileName(p)).string()) {}

  static std::string CreatedDir(const std::string& d) {
    std::filesystem::create_directories(d);
    return d;
  }

  void Write(const void* data, size_t n) {
    file.Write(data, n);
    sha.Update(data, n);
  }
  void PadTo(uint64_t offset) {
    std::string zeros(offset - file.bytes_written(), '\0');
    Write(zeros.data(), zeros.size());
  }
  Section AppendSection(const void* data, size_t bytes, const StepSectionSpec& spec) {
    uint64_t offset =
        (file.bytes_written() + kSectionAlignment - 1) / kSectionAlignment * kSectionAlignment;
    PadTo(offset);
    Write(data, bytes);
    return {offset, spec.dtype, StepSectionShape(spec, frames, action_dim), Crc32c(data, bytes)};
  }
};

TokenPartWriter::TokenPartWriter(std::string dir, int part, int num_parts, const TokenIndex& base)
    : state_(
          std::make_unique<State>(std::move(dir), part, num_parts, RunKey(base, num_parts), base)) {
  std::string header = PartHeader(state_->token_bytes, base.tokenizer);
  state_->Write(header.data(), header.size());
}

TokenPartWriter::~TokenPartWriter() = default;

void TokenPartWriter::AddEpisode(const TokenEpisode& meta, const std::vector<uint32_t>& tokens,
                                 const Episode& steps) {
  State& s = *state_;
  const int64_t per_frame = s.tokenizer.tokens_per_frame();
  const std::string& where = meta.episode_key;
  Check(meta.num_frames > 0, "an episode needs at least one frame", {.file = where});
  const auto n = static_cast<size_t>(meta.num_frames);
  Check(steps.action_dim == s.action_dim,
        "episode has " + std::to_string(steps.action_dim) + "-dim actions, the dataset " +
            std::to_string(s.action_dim),
        {.file = where});
  Check(steps.actions.size() == n * static_cast<size_t>(s.action_dim) &&
            steps.rewards.size() == n && steps.discounts.size() == n &&
            steps.is_first.size() == n && steps.is_last.size() == n &&
            steps.is_terminal.size() == n,
        "per-step arrays do not have num_frames rows", {.file = where});
  Check(steps.num_steps == meta.num_frames &&
            static_cast<int64_t>(tokens.size()) == meta.num_frames * per_frame,
        "token count " + std::to_string(tokens.size()) + " != num_frames x levels x grid (" +
            std::to_string(meta.num_frames) + " x " + std::to_string(per_frame) + ")",
        {.file = where});
  for (uint32_t t : tokens) {
    Check(t < static_cast<uint64_t>(s.tokenizer.num_codes), "token id out of range",
          {.file = where});
  }
  if (s.token_bytes == 2) {
    std::vector<uint16_t> narrow(tokens.begin(), tokens.end());
    s.Write(narrow.data(), narrow.size() * 2);
    s.token_crc = Crc32c(narrow.data(), narrow.size() * 2, s.token_crc);
  } else {
    s.Write(tokens.data(), tokens.size() * 4);
    s.token_crc = Crc32c(tokens.data(), tokens.size() * 4, s.token_crc);
  }
  TokenEpisode e = meta;
  e.part = s.part;
  e.frame_offset = s.frames;
  s.episodes.push_back(e);
  s.frames += meta.num_frames;
  auto append = [](auto& dst, const auto& src) { dst.insert(dst.end(), src.begin(), src.end()); };
  append(s.actions, steps.actions);
  append(s.rewards, steps.rewards);
  append(s.discounts, steps.discounts);
  append(s.is_first, steps.is_first);
  append(s.is_last, steps.is_last);
  append(s.is_terminal, steps.is_terminal);
}

PartInfo TokenPartWriter::Finish() {
  State& s = *state_;
  Check(!s.finished, "Finish called twice", {.file = s.file.path()});
  PartInfo info;
  info.file = PartFileName(s.part);
  info.num_episodes = static_cast<int64_t>(s.episodes.size());
  info.num_frames = s.frames;
  info.sections["tokens"] = {kPartHeaderSize, s.token_bytes == 2 ? "<u2" : "<u4",
                             TokenSectionShape(s.tokenizer, s.frames), s.token_crc};
  const void* data[] = {s.actions.data(),  s.rewards.data(), s.discounts.data(),
                        s.is_first.data(), s.is_last.data(), s.is_terminal.data()};
  for (size_t i = 0; i < std::size(kStepSections); ++i) {
    const StepSectionSpec& spec = kStepSections[i];
    size_t bytes = DtypeSize(spec.dtype);
    for (int64_t d : StepSectionShape(spec, s.frames, s.action_dim))
      bytes *= static_cast<size_t>(d);
    info.sections[spec.name] = s.AppendSection(data[i], bytes, spec);
  }
  info.bytes = s.file.bytes_written();
  info.sha256 = s.sha.HexDigest();
  s.file.Commit();
  s.finished = true;

  TokenIndex one;  // reuse the index's JSON spelling for the part's entries
  one.parts = {info};
  one.episodes = s.episodes;
  nlohmann::json j = TokenIndexToJson(one);
  nlohmann::json part_json = {
      {"part_index", s.part},  {"num_parts", s.num_parts},
      {"run_key", s.run_key},  {"tokenizer_sha256", s.tokenizer.checkpoint_sha256},
      {"part", j["parts"][0]}, {"episodes", j["episodes"]}};
  WriteFileAtomically((std::filesystem::path(s.dir) / PartJsonName(s.part)).string(),
                      part_json.dump(2) + "\n");
  return info;
}

}  // namespace wm::tokens

// Fuzz target: a token dataset (core/tokens/token_dataset.h). The input is index.json, a NUL
// byte, then the bytes of part-00000.wmtok; every episode's tokens and per-step arrays are read.
// Like shard_fuzz.cc, each input runs as given and then with its checksums (header CRC, the
// sections' crc32c and the part's byte count in index.json) recomputed.
#include <nlohmann/json.hpp>

#include "core/crc32c.h"
#include "core/json_int.h"
#include "core/shard/shard_format.h"
#include "core/tokens/token_dataset.h"
#include "core/tokens/token_format.h"
#include "tests/fuzz/fuzz_util.h"

using namespace wm;
using nlohmann::json;

namespace {

// index.json with each part's byte count and each in-range section's crc32c matching `part`,
// whose header CRC is fixed in place; `index` unchanged when it is not the expected JSON.
std::string WithValidChecksums(const std::string& index, std::string& part) {
  if (part.size() >= tokens::kPartHeaderSize) {
    const uint32_t crc = Crc32c(reinterpret_cast<const uint8_t*>(part.data()), 60);
    for (int i = 0; i < 4; ++i) part[60 + i] = static_cast<char>(crc >> (8 * i));
  }
  json j = json::parse(index, nullptr, /*allow_exceptions=*/false);
  try {
    for (json& p : j.at("parts")) {
      p.at("bytes") = part.size();
      for (json& s : p.at("sections")) {
        // JsonInts: get<> would cast a damaged 1e88 to an integer (UB).
        const std::optional<uint64_t> bytes = tokens::SectionByteSize(
            s.at("dtype").get<std::string>(), JsonInts<int64_t>(s.at("shape")));
        const uint64_t offset = JsonInt<uint64_t>(s.at("offset"));
        if (!bytes || offset > part.size() || *bytes > part.size() - offset) continue;
        s.at("crc32c") = Crc32c(reinterpret_cast<const uint8_t*>(part.data()) + offset, *bytes);
      }
    }
  } catch (const std::exception&) {  // json or wm errors: not shaped like an index
    return index;
  }
  return j.dump();
}

void ReadAll(const std::string& index, const std::string& part) {
  fuzz::WriteTempFile("index.json", index);
  fuzz::WriteTempFile("part-00000.wmtok", part);
  fuzz::AcceptWmError([&] {
    tokens::TokenDataset tokens(fuzz::TempDir());
    uint64_t sum = 0;  // every value is used, so no read is optimised away
    for (int64_t k = 0; k < tokens.num_episodes(); ++k) {
      const int64_t frames = tokens.episode(k).num_frames;
      std::vector<int64_t> codes(static_cast<size_t>(frames * tokens.tokens_per_frame()));
      tokens.CopyTokens(k, 0, frames, codes.data());
      for (int64_t c : codes) sum += static_cast<uint64_t>(c);
      for (int64_t i = 0; i < frames * tokens.action_dim(); ++i) sum += tokens.actions(k)[i] > 0;
      for (int64_t i = 0; i < frames; ++i) {
        sum += (tokens.rewards(k)[i] > 0) + (tokens.discounts(k)[i] > 0) + tokens.is_first(k)[i] +
               tokens.is_last(k)[i] + tokens.is_terminal(k)[i];
      }
    }
    static volatile uint64_t sink;
    sink = sum;
    (void)sink;
  });
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes = fuzz::Bytes(data, size);
  const size_t split = std::min(bytes.find('\0'), bytes.size());
  const std::string index(bytes.substr(0, split));
  std::string part(bytes.substr(std::min(split + 1, bytes.size())));
  ReadAll(index, part);
  const std::string original_part = part;
  const std::string fixed_index = WithValidChecksums(index, part);
  if (fixed_index != index || part != original_part) ReadAll(fixed_index, part);
  return 0;
}

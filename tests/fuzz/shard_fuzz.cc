// Fuzz target: one shard file (core/shard/shard_reader.h, episode_codec.h), every episode read
// with and without images. Each input runs twice: as given, then with every checksum it holds
// recomputed, because a mutation rarely keeps four CRCs right and would never reach the index
// and record decoding behind them.
#include "core/crc32c.h"
#include "core/shard/shard_reader.h"
#include "tests/fuzz/fuzz_util.h"

using namespace wm;
using namespace wm::shard;

namespace {

void SetLittleEndian(uint8_t* p, uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}
void SetU32(uint8_t* p, uint32_t v) { SetLittleEndian(p, v, 4); }

// The same bytes with the header, record, footer-index and trailer CRCs made to match, where
// the fields locating them are in range, and the index count fitted to the file size
// (docs/shard-format.md).
std::string WithValidCrcs(std::string file) {
  auto* p = reinterpret_cast<uint8_t*>(file.data());
  const size_t n = file.size();
  if (n < kFileHeaderSize + kTrailerSize) return file;
  SetU32(p + 12, Crc32c(p, 12));
  uint8_t* t = p + n - kTrailerSize;
  const uint64_t index_offset = GetU64(t);
  if (index_offset >= kFileHeaderSize && index_offset <= n - kTrailerSize) {
    const uint64_t count = (n - kTrailerSize - index_offset) / kIndexEntrySize;
    SetLittleEndian(t + 8, count, 8);
    for (uint64_t i = 0; i < count; ++i) {
      const uint8_t* e = p + index_offset + i * kIndexEntrySize;
      const uint64_t offset = GetU64(e), length = GetU64(e + 8);
      if (offset <= index_offset && length >= kRecordHeaderSize &&
          length <= index_offset - offset) {
        SetU32(p + offset + 4, Crc32c(p + offset + 8, length - 8));
      }
    }
    SetU32(t + 16, Crc32c(p + index_offset, count * kIndexEntrySize));
  }
  SetU32(t + 28, Crc32c(t, 28));
  return file;
}

void ReadAll(const std::string& path) {
  fuzz::AcceptWmError([&] {
    ShardReader reader(path);
    for (size_t k = 0; k < reader.num_episodes(); ++k) {
      fuzz::AcceptWmError([&] { reader.ReadMeta(k); });
      fuzz::AcceptWmError([&] { reader.ReadEpisode(k, /*with_images=*/true); });
      fuzz::AcceptWmError([&] { reader.ReadEpisode(k, /*with_images=*/false); });
    }
    std::vector<float> actions;
    reader.AppendActions(actions);
  });
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(fuzz::Bytes(data, size));
  ReadAll(fuzz::WriteTempFile("input.wms", bytes));
  const std::string repaired = WithValidCrcs(bytes);
  if (repaired != bytes) ReadAll(fuzz::WriteTempFile("input.wms", repaired));
  return 0;
}

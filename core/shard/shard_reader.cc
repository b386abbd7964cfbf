#include "core/shard/shard_reader.h"

#include <cstring>

#include "core/crc32c.h"
#include "core/error.h"
#include "core/shard/episode_codec.h"

namespace wm::shard {
namespace {

void CheckVersion(uint32_t version, const std::string& file, const std::string& where) {
  if (version != kFormatVersion) {
    throw Error("unknown shard format version " + std::to_string(version) + " in the " + where +
                    " (this build reads version " + std::to_string(kFormatVersion) + ")",
                {.file = file});
  }
}

}  // namespace

ShardReader::ShardReader(const std::string& path) : file_(std::make_unique<MappedFile>(path)) {
  const uint8_t* p = file_->data();
  const size_t n = file_->size();
  auto fail = [&](const std::string& where, const std::string& what) {
    throw Error(where + ": " + what, {.file = path});
  };
  if (n < kFileHeaderSize + kTrailerSize) {
    fail("file", "truncated: " + std::to_string(n) + " bytes is smaller than header + trailer");
  }
  if (std::memcmp(p, kFileMagic, 8) != 0) fail("file header", "bad magic, not a wmkit shard");
  if (Crc32c(p, 12) != GetU32(p + 12)) fail("file header", "CRC mismatch");
  CheckVersion(GetU32(p + 8), path, "file header");

  const uint8_t* t = p + n - kTrailerSize;
  if (std::memcmp(t + 32, kTrailerMagic, 8) != 0) {
    fail("trailer", "bad magic (truncated or unfinished shard)");
  }
  if (Crc32c(t, 28) != GetU32(t + 28)) fail("trailer", "CRC mismatch");
  CheckVersion(GetU32(t + 20), path, "trailer");
  uint64_t index_offset = GetU64(t), count = GetU64(t + 8);
  // count is compared by division: count * kIndexEntrySize can wrap around for a damaged count.
  if (index_offset < kFileHeaderSize || index_offset > n - kTrailerSize ||
      (n - kTrailerSize - index_offset) % kIndexEntrySize != 0 ||
      (n - kTrailerSize - index_offset) / kIndexEntrySize != count) {
    fail("trailer", "footer index offset/count do not match the file size");
  }
  const uint8_t* idx = p + index_offset;
  if (Crc32c(idx, count * kIndexEntrySize) != GetU32(t + 16)) fail("footer index", "CRC mismatch");
  entries_.resize(count);
  for (uint64_t i = 0; i < count; ++i) {
    const uint8_t* e = idx + i * kIndexEntrySize;
    entries_[i] = {GetU64(e), GetU64(e + 8), GetU32(e + 16)};
    if (entries_[i].offset < kFileHeaderSize || entries_[i].length < kRecordHeaderSize ||
        entries_[i].offset > index_offset ||
        entries_[i].length > index_offset - entries_[i].offset) {
      fail("footer index", "entry " + std::to_string(i) + " points outside the record area");
    }
  }
}

std::string_view ShardReader::RecordBytes(size_t k) const {
  Check(k < entries_.size(),
        "episode " + std::to_string(k) + " out of range (shard holds " +
            std::to_string(entries_.size()) + ")",
        {.file = path()});
  const IndexEntry& e = entries_[k];
  const uint8_t* r = file_->data() + e.offset;
  ErrorContext where{.file = path(), .record = static_cast<int64_t>(k)};
  Check(std::memcmp(r, kRecordMagic, 4) == 0, "bad record magic", where);
  uint64_t meta_len = GetU64(r + 8), body_len = GetU64(r + 16);
  Check(meta_len <= e.length && body_len <= e.length &&
            kRecordHeaderSize + meta_len + body_len == e.length,
        "record lengths disagree with the footer index", where);
  Check(Crc32c(r + 8, e.length - 8) == GetU32(r + 4), "record CRC mismatch (corrupt data)", where);
  return {reinterpret_cast<const char*>(r), e.length};
}

void ShardReader::AppendActions(std::vector<float>& out) const {
  for (size_t k = 0; k < entries_.size(); ++k) {
    Episode e = ReadEpisode(k, /*with_images=*/false);
    out.insert(out.end(), e.actions.begin(), e.actions.end());
  }
}

std::string ShardReader::ReadMeta(size_t k) const {
  std::string_view rec = RecordBytes(k);
  uint64_t meta_len = GetU64(reinterpret_cast<const uint8_t*>(rec.data()) + 8);
  return std::string(rec.substr(kRecordHeaderSize, meta_len));
}

Episode ShardReader::ReadEpisode(size_t k, bool with_images) const {
  std::string_view rec = RecordBytes(k);
  uint64_t meta_len = GetU64(reinterpret_cast<const uint8_t*>(rec.data()) + 8);
  try {
    return DecodeEpisode(rec.substr(kRecordHeaderSize, meta_len),
                         rec.substr(kRecordHeaderSize + meta_len), with_images);
  } catch (const Error& e) {
    throw e.WithRecord(static_cast<int64_t>(k)).WithFile(path());
  }
}

}  // namespace wm::shard

#include "core/shard/shard_writer.h"

#include "core/crc32c.h"
#include "core/shard/episode_codec.h"

namespace wm::shard {

std::string ShardFileName(int number) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "shard-%05d.wms", number);
  return buf;
}

ShardWriter::ShardWriter(const std::string& path, int zstd_level)
    : file_(path), zstd_level_(zstd_level) {
  std::string header(kFileMagic, 8);
  PutU32(header, kFormatVersion);
  PutU32(header, Crc32c(header));
  file_.Write(header);
}

void ShardWriter::Append(const Episode& episode) {
  EncodedRecord rec = EncodeEpisode(episode, zstd_level_);
  std::string lengths;
  PutU64(lengths, rec.meta.size());
  PutU64(lengths, rec.body.size());
  uint32_t crc = Crc32c(rec.body, Crc32c(rec.meta, Crc32c(lengths)));
  std::string head(kRecordMagic, 4);
  PutU32(head, crc);
  head += lengths;
  IndexEntry entry{file_.bytes_written(), head.size() + rec.meta.size() + rec.body.size(),
                   static_cast<uint32_t>(episode.num_steps)};
  file_.Write(head);
  file_.Write(rec.meta);
  file_.Write(rec.body);
  entries_.push_back(entry);
  steps_ += static_cast<uint64_t>(episode.num_steps);
}

void ShardWriter::Finish() {
  std::string index;
  for (const auto& e : entries_) {
    PutU64(index, e.offset);
    PutU64(index, e.length);
    PutU32(index, e.num_steps);
    PutU32(index, 0);
  }
  std::string trailer;
  PutU64(trailer, file_.bytes_written());
  PutU64(trailer, entries_.size());
  PutU32(trailer, Crc32c(index));
  PutU32(trailer, kFormatVersion);
  PutU32(trailer, 0);
  PutU32(trailer, Crc32c(trailer));
  trailer.append(kTrailerMagic, 8);
  file_.Write(index);
  file_.Write(trailer);
  file_.Commit();
}

}  // namespace wm::shard

#pragma once
// Reads one shard file through a memory map: opening checks header, trailer and footer index;
// reading an episode checks its record CRC. Every failure names the file and record.
#include <memory>
#include <string>
#include <vector>

#include "core/episode.h"
#include "core/mapped_file.h"
#include "core/shard/shard_format.h"

namespace wm::shard {

class ShardReader {
 public:
  explicit ShardReader(const std::string& path);
  size_t num_episodes() const { return entries_.size(); }
  const std::vector<IndexEntry>& entries() const { return entries_; }
  const std::string& path() const { return file_->path(); }

  Episode ReadEpisode(size_t k, bool with_images = true) const;
  // Appends every episode's [T, 7] actions (checked records, images not decoded).
  void AppendActions(std::vector<float>& out) const;
  // The meta JSON of record k (checked), without decoding the body.
  std::string ReadMeta(size_t k) const;
  // The raw record bytes (header + meta + body) after checking them; used by merge and tests.
  std::string_view RecordBytes(size_t k) const;

 private:
  std::unique_ptr<MappedFile> file_;
  std::vector<IndexEntry> entries_;
};

}  // namespace wm::shard

#include "ingest/rlds/tfrecord.h"

#include "core/crc32c.h"
#include "core/error.h"
#include "core/shard/shard_format.h"

namespace wm::rlds {
using shard::GetU32;
using shard::GetU64;

TfRecordReader::TfRecordReader(const std::string& path)
    : file_(std::make_unique<MappedFile>(path)) {
  const uint8_t* p = file_->data();
  const uint64_t n = file_->size();
  uint64_t pos = 0;
  while (pos < n) {
    ErrorContext where{.file = path, .record = static_cast<int64_t>(offsets_.size())};
    Check(n - pos >= 12, "truncated TFRecord header (" + std::to_string(n - pos) +
                             " bytes left at offset " + std::to_string(pos) + ")",
          where);
    Check(MaskCrc(Crc32c(p + pos, 8)) == GetU32(p + pos + 8),
          "TFRecord length CRC mismatch at offset " + std::to_string(pos) + " (corrupt file)",
          where);
    uint64_t len = GetU64(p + pos);
    Check(len <= n - pos - 12 && n - pos - 12 - len >= 4,
          "truncated TFRecord: record of " + std::to_string(len) + " bytes at offset " +
              std::to_string(pos) + " runs past the end of the file",
          where);
    offsets_.push_back(pos);
    pos += 12 + len + 4;
  }
}

std::string_view TfRecordReader::Record(size_t k) const {
  const uint8_t* p = file_->data() + offsets_.at(k);
  uint64_t len = GetU64(p);
  Check(MaskCrc(Crc32c(p + 12, len)) == GetU32(p + 12 + len),
        "TFRecord data CRC mismatch (corrupt record)",
        {.file = path(), .record = static_cast<int64_t>(k)});
  return {reinterpret_cast<const char*>(p + 12), len};
}

void TfRecordWriter::Write(std::string_view record) {
  std::string head;
  shard::PutU64(head, record.size());
  shard::PutU32(head, MaskCrc(Crc32c(head)));
  std::string tail;
  shard::PutU32(tail, MaskCrc(Crc32c(record)));
  file_.Write(head);
  file_.Write(record);
  file_.Write(tail);
}

}  // namespace wm::rlds

#include "ingest/rlds/tfrecord.h"

#include <fstream>

#include "core/crc32c.h"
#include "core/error.h"
#include "core/shard/shard_format.h"
#include "core/tfrecord_frame.h"

namespace wm::rlds {
using shard::GetU32;
using shard::GetU64;

namespace {
// Why the record framed at offset `pos` is damaged, or "" when its header is intact. `head`: the
// record's first bytes (12 are read when `left`, the file's bytes from `pos` on, allows).
std::string FramingProblem(const uint8_t* head, uint64_t left, uint64_t pos) {
  if (left < 12) {
    return "truncated TFRecord header (" + std::to_string(left) + " bytes left at offset " +
           std::to_string(pos) + ")";
  }
  if (MaskCrc(Crc32c(head, 8)) != GetU32(head + 8)) {
    return "TFRecord length CRC mismatch at offset " + std::to_string(pos) + " (corrupt file)";
  }
  uint64_t len = GetU64(head);
  if (len > left - 12 || left - 12 - len < 4) {
    return "truncated TFRecord: record of " + std::to_string(len) + " bytes at offset " +
           std::to_string(pos) + " runs past the end of the file";
  }
  return "";
}
}  // namespace

TfRecordReader::TfRecordReader(const std::string& path, bool stop_at_damage)
    : file_(std::make_unique<MappedFile>(path)) {
  const uint8_t* p = file_->data();
  const uint64_t n = file_->size();
  for (uint64_t pos = 0; pos < n; pos += 12 + GetU64(p + pos) + 4) {
    std::string problem = FramingProblem(p + pos, n - pos, pos);
    if (!problem.empty()) {
      if (stop_at_damage) break;
      throw Error(problem, {.file = path, .record = static_cast<int64_t>(offsets_.size())});
    }
    offsets_.push_back(pos);
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

std::vector<uint64_t> ScanTfRecordOffsets(const std::string& path, bool stop_at_damage) {
  return TfRecordReader(path, stop_at_damage).record_offsets();
}

std::string ReadTfRecordAt(const std::string& path, uint64_t offset) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  Check(in.good(), "cannot open TFRecord file", {.file = path});
  const auto size = static_cast<uint64_t>(in.tellg());
  const uint64_t left = offset <= size ? size - offset : 0;
  uint8_t head[12] = {};
  if (left >= 12) {
    in.seekg(static_cast<std::streamoff>(offset));
    Check(in.read(reinterpret_cast<char*>(head), 12).good(),
          "cannot read TFRecord header at offset " + std::to_string(offset), {.file = path});
  }
  // The length is checked against the file size before it sizes the buffer: a damaged length
  // must be an error, not a multi-exabyte allocation.
  const std::string problem = FramingProblem(head, left, offset);
  Check(problem.empty(), problem, {.file = path});
  uint64_t len = GetU64(head);
  std::string data(len + 4, '\0');
  Check(in.read(data.data(), static_cast<std::streamsize>(data.size())).good(),
        "truncated TFRecord record at offset " + std::to_string(offset), {.file = path});
  uint32_t crc = GetU32(reinterpret_cast<const uint8_t*>(data.data()) + len);
  data.resize(len);
  Check(MaskCrc(Crc32c(data)) == crc, "TFRecord data CRC mismatch (corrupt record)",
        {.file = path});
  return data;
}

void TfRecordWriter::Write(std::string_view record) { file_.Write(FrameTfRecord(record)); }

}  // namespace wm::rlds

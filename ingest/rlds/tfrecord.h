#pragma once
// TFRecord framing: per record u64 length, u32 masked CRC32C(length), data, u32 masked
// CRC32C(data). The reader memory-maps the file and checks both CRCs of every record it returns.
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/atomic_file.h"
#include "core/mapped_file.h"

namespace wm::rlds {

class TfRecordReader {
 public:
  // With `stop_at_damage`, a damaged tail ends the scan instead of throwing; records() then
  // holds the intact records before it.
  explicit TfRecordReader(const std::string& path, bool stop_at_damage = false);
  // Scans the framing (length CRCs only) and returns each record's offset; throws wm::Error
  // naming the file and record on a truncated file or a bad length CRC.
  const std::vector<uint64_t>& record_offsets() const { return offsets_; }
  size_t num_records() const { return offsets_.size(); }
  // Record k's payload after checking its data CRC.
  std::string_view Record(size_t k) const;
  const std::string& path() const { return file_->path(); }

 private:
  std::unique_ptr<MappedFile> file_;
  std::vector<uint64_t> offsets_;
};

// Offsets of the intact records (see TfRecordReader's `stop_at_damage`).
std::vector<uint64_t> ScanTfRecordOffsets(const std::string& path, bool stop_at_damage);

// Reads and checks the one record that starts at `offset` (positioned reads, no full scan).
std::string ReadTfRecordAt(const std::string& path, uint64_t offset);

class TfRecordWriter {
 public:
  explicit TfRecordWriter(const std::string& path) : file_(path) {}
  void Write(std::string_view record);
  void Close() { file_.Commit(); }

 private:
  AtomicFileWriter file_;
};

}  // namespace wm::rlds

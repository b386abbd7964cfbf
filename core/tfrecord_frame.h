#pragma once
// TFRecord framing (TensorFlow's record_writer): per record a u64 little-endian length, the
// masked CRC32C of those 8 bytes, the record, and the masked CRC32C of the record. Shared by the
// RLDS writer (ingest/rlds/tfrecord.h) and the TensorBoard event files (core/tensorboard_events.h).
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/crc32c.h"

namespace wm {

// The record framed: length, its masked CRC, the bytes, their masked CRC.
inline std::string FrameTfRecord(std::string_view record) {
  auto put = [](std::string& out, uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
  };
  std::string out;
  put(out, record.size(), 8);
  put(out, MaskCrc(Crc32c(out)), 4);
  out.append(record);
  put(out, MaskCrc(Crc32c(record)), 4);
  return out;
}

// The records of framed `bytes`, in order, up to the first that is truncated or fails a CRC
// (a file cut by a kill mid-append keeps the records before the cut). Views into `bytes`.
inline std::vector<std::string_view> UnframeTfRecords(std::string_view bytes) {
  auto get = [&](size_t pos, int n) {
    uint64_t v = 0;
    for (int i = n - 1; i >= 0; --i) v = v << 8 | static_cast<uint8_t>(bytes[pos + i]);
    return v;
  };
  std::vector<std::string_view> records;
  size_t pos = 0;
  while (bytes.size() - pos >= 16) {
    const uint64_t n = get(pos, 8);
    if (get(pos + 8, 4) != MaskCrc(Crc32c(bytes.substr(pos, 8))) || bytes.size() - pos - 16 < n)
      break;
    const std::string_view record = bytes.substr(pos + 12, n);
    if (get(pos + 12 + n, 4) != MaskCrc(Crc32c(record))) break;
    records.push_back(record);
    pos += 16 + n;
  }
  return records;
}

}  // namespace wm

#pragma once
// TFRecord framing (TensorFlow's record_writer): per record a u64 little-endian length, the
// masked CRC32C of those 8 bytes, the record, and the masked CRC32C of the record. Shared by the
// RLDS writer (ingest/rlds/tfrecord.h) and the TensorBoard event files (core/tensorboard_events.h).
#include <cstdint>
#include <string>
#include <string_view>

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

}  // namespace wm

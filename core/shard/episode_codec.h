#pragma once
// Episode <-> record bytes (meta JSON + body sections), the part of a shard record that the
// CRC protects. See docs/shard-format.md, "Record".
#include <string>
#include <string_view>

#include "core/episode.h"

namespace wm::shard {

struct EncodedRecord {
  std::string meta;  // UTF-8 JSON
  std::string body;  // sections
};

EncodedRecord EncodeEpisode(const Episode& episode, int zstd_level);
// Throws wm::Error (key = section name) on a malformed meta or body.
// `with_images` false skips the image sections (statistics passes read only numbers).
Episode DecodeEpisode(std::string_view meta, std::string_view body, bool with_images = true);

}  // namespace wm::shard

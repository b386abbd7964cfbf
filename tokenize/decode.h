#pragma once
// Token dataset episodes back to pixels for inspection: an MP4, a PNG contact sheet (with the
// original frames above the decoded ones when the source shards are given), or PNG files.
#include <cstdint>
#include <string>

namespace wm::tokenize {

struct DecodeOptions {
  std::string checkpoint;  // the tokenizer that wrote the tokens (its sha256 is checked)
  std::string tokens_dir;
  int64_t episode = 0;
  // "x.mp4" -> video (H.264, docs/videos.md); "x.png" -> contact sheet, `columns` frames per
  // row; anything else -> a directory of frame_NNNN.png.
  std::string out;
  std::string originals_dir;  // the source shard dataset: adds the original frames (optional)
  int columns = 10;
  std::string device = "cpu";
};

// Returns the number of frames decoded. Throws wm::Error naming the file on a tokenizer that
// differs from the one recorded in the token index, a bad episode index, or a write failure.
int64_t DecodeEpisode(const DecodeOptions& options);

}  // namespace wm::tokenize

#pragma once
// Pre-tokenizing: shard dataset -> token dataset (docs/token-format.md) with a trained
// tokenizer, one part per job so Slurm array tasks can share the work.
#include <cstdint>
#include <string>

namespace wm::tokenize {

struct EncodeOptions {
  std::string checkpoint;  // tokenizer run directory or its checkpoint.wmt
  std::string data_dir;    // shard dataset directory (index.json)
  std::string out_dir;     // TOKENS_DIR, created if missing
  int shard_index = 0;     // this job's part: source episodes PartEpisodeRange(.., i, n)
  int num_shards = 1;
  std::string device = "cpu";
  int threads = 1;        // LibTorch intra-op threads
  double hysteresis = 0;  // code hysteresis margin (Tokenizer::EncodeEpisode); 0 = none
  bool show_progress = true;
};

struct EncodeSummary {
  int64_t episodes = 0, frames = 0;  // encoded by this job (0 when the part already existed)
  bool skipped = false;              // the part was already complete (a rerun after a kill)
  bool index_written = false;        // every part exists now and index.json was assembled
};

// Throws wm::Error naming the file on unreadable data, a bad checkpoint, or a shard index
// outside [0, num_shards).
EncodeSummary EncodeDataset(const EncodeOptions& options);

}  // namespace wm::tokenize

#include "tokenize/encode.h"

#include <torch/torch.h>

#include <filesystem>
#include <optional>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/provenance.h"
#include "core/read_ahead.h"
#include "core/shard/dataset_reader.h"
#include "core/tokens/token_dataset.h"
#include "core/tokens/token_format.h"
#include "tokenize/frame_sampler.h"
#include "tokenize/tokenizer.h"
#include "trainkit/torch_runtime.h"

namespace wm::tokenize {
namespace fs = std::filesystem;
namespace {

tokens::TokenIndex BaseIndex(const Tokenizer& tok, const shard::DatasetIndex& source,
                             double hysteresis) {
  tokens::TokenIndex x;
  x.dataset = source.dataset;
  x.split = source.split;
  x.tokenizer = {.checkpoint_sha256 = tok.checkpoint_sha256(),
                 .config_hash = tok.config_hash(),
                 .num_codes = tok.config().model.num_codes,
                 .grid_h = tok.grid(),
                 .grid_w = tok.grid(),
                 .levels = static_cast<int>(tok.levels()),
                 .image_size = tok.image_size(),
                 .image_key = tok.config().data.image_key};
  x.token_dtype = x.tokenizer.num_codes > 65536 ? "uint32" : "uint16";
  nlohmann::json shards = nlohmann::json::array();
  for (const auto& s : source.shards) shards.push_back({{"file", s.file}, {"sha256", s.sha256}});
  x.source = {{"dataset", source.dataset},
              {"split", source.split},
              {"index_config_hash", source.provenance.value("config_hash", "")},
              {"num_episodes", source.num_episodes},
              {"shards", shards}};
  x.action_stats = source.action_stats;
  x.action_dim = shard::ActionDimOf(source.features);
  x.action_space = shard::ActionSpaceOf(source.features);
  // The same for every part job, so whichever job finishes last writes the same index.json.
  x.provenance =
      MakeProvenance("wm-tokenize encode",
                     {{"tokenizer_sha256", tok.checkpoint_sha256()}, {"hysteresis", hysteresis}},
                     trainkit::TorchLibraryVersions());
  return x;
}

// The episode's frames decoded and resized for the tokenizer, [T, 3, S, S].
std::vector<float> EpisodeFrames(const Episode& e, const std::string& key, int size,
                                 const std::string& where) {
  auto it = e.images.find(key);
  Check(it != e.images.end(), "episode has no image stream '" + key + "'", {.file = where});
  const size_t floats = 3ull * size * size;
  std::vector<float> frames(it->second.frames.size() * floats);
  for (size_t t = 0; t < it->second.frames.size(); ++t) {
    try {
      DecodeFrame(it->second.frames[t], size, frames.data() + t * floats);
    } catch (const Error& err) {
      throw err.WithFile(where).WithRecord(static_cast<int64_t>(t), "step");
    }
  }
  return frames;
}

bool PartAlreadyDone(const EncodeOptions& o, const tokens::TokenIndex& base) {
  const fs::path json_path = fs::path(o.out_dir) / tokens::PartJsonName(o.shard_index);
  if (!fs::exists(json_path) ||
      !fs::exists(fs::path(o.out_dir) / tokens::PartFileName(o.shard_index))) {
    return false;
  }
  auto j = nlohmann::json::parse(ReadFile(json_path.string()), nullptr, false);
  return !j.is_discarded() && j.value("run_key", "") == tokens::RunKey(base, o.num_shards);
}

}  // namespace

EncodeSummary EncodeDataset(const EncodeOptions& o) {
  Check(o.num_shards >= 1 && o.shard_index >= 0 && o.shard_index < o.num_shards,
        "--shard-index must be in [0, --num-shards)");
  torch::set_num_threads(o.threads);
  Tokenizer tok(o.checkpoint, o.device);
  shard::DatasetReader reader(o.data_dir);
  fs::create_directories(o.out_dir);
  const tokens::TokenIndex base = BaseIndex(tok, reader.index(), o.hysteresis);
  EncodeSummary summary;
  if (PartAlreadyDone(o, base)) {
    summary.skipped = true;
  } else {
    auto [first, last] = tokens::PartEpisodeRange(static_cast<int64_t>(reader.num_episodes()),
                                                  o.shard_index, o.num_shards);
    // A stale index.json from an earlier run must not outlive the parts it described.
    fs::remove(fs::path(o.out_dir) / tokens::kTokenIndexFileName);
    tokens::TokenPartWriter writer(o.out_dir, o.shard_index, o.num_shards, base);
    std::optional<Progress> progress;
    if (o.show_progress) progress.emplace("encode", last - first, "episodes");
    const std::string key = tok.config().data.image_key;
    auto load = [&](int64_t k) {  // read + decode the next episode while this one encodes
      Episode e = reader.ReadEpisode(static_cast<size_t>(k));
      const std::string where = reader.dir() + " episode " + std::to_string(k);
      std::vector<float> frames = EpisodeFrames(e, key, tok.image_size(), where);
      return std::make_pair(std::move(e), std::move(frames));
    };
    ReadAhead<std::pair<Episode, std::vector<float>>> episodes;
    for (int64_t k = first; k < last; ++k) {
      auto [episode, frames] = episodes.Take(k, last, load);
      const int64_t n =
          static_cast<int64_t>(frames.size()) / (3 * tok.image_size() * tok.image_size());
      std::vector<uint32_t> codes = tok.EncodeEpisode(frames.data(), n, o.hysteresis);  // n = T
      writer.AddEpisode({.num_frames = episode.num_steps,
                         .source_episode = k,
                         .episode_key = episode.episode_key,
                         .policy_id = episode.policy_id,
                         .language_instruction = episode.language_instruction,
                         .episode_seed = episode.episode_seed},
                        codes, episode);
      ++summary.episodes;
      summary.frames += episode.num_steps;
      if (progress) progress->Add(1);
    }
    writer.Finish();
    if (progress) progress->Finish();
  }
  summary.index_written = tokens::AssembleIndexIfComplete(o.out_dir, o.num_shards, base);
  return summary;
}

}  // namespace wm::tokenize

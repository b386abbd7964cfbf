#include "motion/window_sampler.h"

#include <algorithm>
#include <random>

#include "core/error.h"
#include "core/mix_bits.h"
#include "core/shard/dataset_reader.h"
#include "trainkit/frame_decode.h"

namespace wm::motion {

WindowSampler::WindowSampler(const std::string& dir, std::string image_key, int size, int unroll)
    : reader_(std::make_unique<shard::DatasetReader>(dir)),
      image_key_(std::move(image_key)),
      size_(size),
      unroll_(unroll) {
  const shard::DatasetIndex& index = reader_->index();
  norm_.mean.assign(index.action_stats.mean.begin(), index.action_stats.mean.end());
  norm_.std.assign(index.action_stats.std.begin(), index.action_stats.std.end());
  action_space_ = shard::ActionSpaceOf(index.features);
  uint64_t windows = 0;
  for (size_t k = 0; k < reader_->num_episodes(); ++k) {
    const auto [shard, local] = reader_->Locate(k);  // the footer index: no episode is read
    const int64_t steps = reader_->shard(shard).entries()[local].num_steps;
    if (steps <= unroll) continue;
    episodes_.push_back(static_cast<int64_t>(k));
    window_prefix_.push_back(windows += static_cast<uint64_t>(steps - unroll));
  }
  Check(!episodes_.empty(),
        "no episode has more than train.unroll = " + std::to_string(unroll) + " steps",
        {.file = dir});
}

WindowSampler::~WindowSampler() = default;

std::vector<WindowRef> WindowSampler::Draw(uint64_t seed, int64_t step, int batch) const {
  std::mt19937_64 rng(MixBits(seed ^ MixBits(static_cast<uint64_t>(step))));
  std::vector<WindowRef> refs;
  for (int b = 0; b < batch; ++b) {
    const uint64_t w = rng() % window_prefix_.back();  // bias < 2^-40 at these counts
    const size_t e =
        std::upper_bound(window_prefix_.begin(), window_prefix_.end(), w) - window_prefix_.begin();
    const uint64_t first = e ? window_prefix_[e - 1] : 0;
    refs.push_back({episodes_[e], static_cast<int64_t>(w - first)});
  }
  return refs;
}

void WindowSampler::Load(const std::vector<WindowRef>& refs, float* frames, float* actions) const {
  const size_t frame_floats = 3ull * size_ * size_;
  const int64_t D = action_dim(), U = unroll_;
  for (size_t b = 0; b < refs.size(); ++b) {
    const Episode episode = reader_->ReadEpisode(static_cast<size_t>(refs[b].episode));
    const std::vector<std::string>& encoded = episode.images.at(image_key_).frames;
    const int64_t t = refs[b].start;
    float* out = frames + b * (U + 2) * frame_floats;
    for (int64_t j = 0; j < U + 2; ++j) {  // t-1 (clamped), t, ..., t+U
      const int64_t frame = std::max<int64_t>(t + j - 1, 0);
      trainkit::DecodeFrame(encoded.at(static_cast<size_t>(frame)), size_, out + j * frame_floats);
    }
    norm_.Apply(episode.actions.data() + t * D, actions + b * U * D, U);
  }
}

std::vector<PairRef> WindowSampler::DrawPairs(uint64_t seed, int64_t step, int batch,
                                              int window) const {
  std::mt19937_64 rng(MixBits(seed ^ MixBits(static_cast<uint64_t>(step))));
  std::vector<PairRef> refs;
  for (int b = 0; b < batch; ++b) {
    const size_t e = rng() % episodes_.size();
    const auto steps =
        static_cast<int64_t>(window_prefix_[e] - (e ? window_prefix_[e - 1] : 0)) + unroll_;
    const auto frame = static_cast<int64_t>(rng() % static_cast<uint64_t>(steps));
    const int64_t reach = window > 0 ? window : steps;  // no window: the whole episode
    const int64_t first = std::max<int64_t>(frame - reach, 0);
    const int64_t last = std::min<int64_t>(frame + reach, steps - 1);
    const auto source =
        first + static_cast<int64_t>(rng() % static_cast<uint64_t>(last - first + 1));
    refs.push_back({episodes_[e], frame, source});
  }
  return refs;
}

void WindowSampler::LoadPairs(const std::vector<PairRef>& refs, float* frames,
                              float* sources) const {
  const size_t frame_floats = 3ull * size_ * size_;
  for (size_t b = 0; b < refs.size(); ++b) {
    const Episode episode = reader_->ReadEpisode(static_cast<size_t>(refs[b].episode));
    const std::vector<std::string>& encoded = episode.images.at(image_key_).frames;
    trainkit::DecodeFrame(encoded.at(static_cast<size_t>(refs[b].frame)), size_,
                          frames + b * frame_floats);
    trainkit::DecodeFrame(encoded.at(static_cast<size_t>(refs[b].source)), size_,
                          sources + b * frame_floats);
  }
}

EpisodeClip WindowSampler::Clip(int64_t k, int64_t max_frames) const {
  const size_t frame_floats = 3ull * size_ * size_;
  const Episode episode = reader_->ReadEpisode(static_cast<size_t>(k));
  EpisodeClip clip;
  clip.frames = std::min(episode.num_steps, max_frames);
  clip.pixels.resize(clip.frames * frame_floats);
  for (int64_t t = 0; t < clip.frames; ++t) {
    trainkit::DecodeFrame(episode.images.at(image_key_).frames.at(static_cast<size_t>(t)), size_,
                          clip.pixels.data() + t * frame_floats);
  }
  clip.actions.assign(episode.actions.begin(),
                      episode.actions.begin() + clip.frames * action_dim());
  return clip;
}

std::vector<EpisodeClip> WindowSampler::Episodes(int count, int64_t max_frames) const {
  std::vector<EpisodeClip> clips;
  for (size_t k = 0; k < reader_->num_episodes() && clips.size() < size_t(count); ++k)
    clips.push_back(Clip(static_cast<int64_t>(k), max_frames));
  return clips;
}

std::string WindowSampler::dataset_name() const { return reader_->index().dataset; }

nlohmann::json WindowSampler::DataProvenance() const {
  const shard::DatasetIndex& index = reader_->index();
  nlohmann::json shards = nlohmann::json::array();
  for (const auto& s : index.shards) shards.push_back({{"file", s.file}, {"sha256", s.sha256}});
  return {{"dataset", index.dataset},
          {"split", index.split},
          {"index_config_hash", index.provenance.value("config_hash", "")},
          {"num_episodes", index.num_episodes},
          {"num_steps", index.num_steps},
          {"shards", shards}};
}

}  // namespace wm::motion

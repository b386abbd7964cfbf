#include "tokenize/frame_sampler.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/mix_bits.h"
#include "core/shard/dataset_reader.h"

namespace wm::tokenize {

FrameSampler::FrameSampler(const std::vector<std::string>& dataset_dirs, std::string image_key,
                           int size, uint64_t seed, std::vector<double> weights)
    : image_key_(std::move(image_key)), size_(size), seed_(seed) {
  Check(!dataset_dirs.empty(), "no datasets given (--data)");
  for (const std::string& dir : dataset_dirs) {
    readers_.push_back(std::make_unique<shard::DatasetReader>(dir));
    Check(readers_.back()->index().num_steps > 0, "dataset has no frames", {.file = dir});
  }
  if (weights.empty()) weights = step_counts();
  Check(weights.size() == readers_.size(), "one mixture weight per dataset is needed");
  double total = 0;
  for (double w : weights) total += w;
  double acc = 0;
  for (double w : weights) weights_prefix_.push_back((acc += w) / total);
  weights_prefix_.back() = 1.0;
}

FrameSampler::~FrameSampler() = default;

namespace {

// The hash key of (batch step, slot): every draw of the slot is MixBits(key + i), i distinct.
uint64_t SlotKey(uint64_t seed, int64_t step, int slot) {
  return MixBits(seed ^ MixBits(static_cast<uint64_t>(step) * 0x10000ull + slot));
}

}  // namespace

std::vector<AnchorRef> FixedGapAnchors(const std::vector<FrameRef>& frames, int gap) {
  std::vector<AnchorRef> anchors;
  for (FrameRef f : frames) {
    const bool blank = f.step == 0;
    f.step -= std::min<size_t>(f.step, static_cast<size_t>(gap));
    anchors.push_back({f, blank});
  }
  return anchors;
}

std::vector<AnchorRef> FrameSampler::TrainingAnchors(const std::vector<FrameRef>& frames,
                                                     int64_t step, int max_gap,
                                                     double dropout) const {
  std::vector<AnchorRef> anchors;
  for (size_t b = 0; b < frames.size(); ++b) {
    const uint64_t key = SlotKey(seed_, step, static_cast<int>(b));
    const double u = static_cast<double>(MixBits(key + 4) >> 11) * 0x1.0p-53;  // [0, 1)
    FrameRef f = frames[b];
    const size_t span = std::min<size_t>(f.step, static_cast<size_t>(max_gap));
    const bool blank = span == 0 || u < dropout;
    if (!blank) f.step -= 1 + MixBits(key + 5) % span;
    anchors.push_back({f, blank});
  }
  return anchors;
}

void FrameSampler::Load(const std::vector<AnchorRef>& anchors, float* out) const {
  Load({}, anchors, nullptr, out);
}

void FrameSampler::Load(const std::vector<FrameRef>& refs, const std::vector<AnchorRef>& anchors,
                        float* frames_out, float* anchors_out) const {
  const size_t floats = 3ull * size_ * size_;
  std::vector<std::pair<FrameRef, float*>> slots;
  for (size_t b = 0; b < refs.size(); ++b) slots.emplace_back(refs[b], frames_out + b * floats);
  for (size_t b = 0; b < anchors.size(); ++b) {
    float* out = anchors_out + b * floats;
    if (anchors[b].blank) {
      std::fill(out, out + floats, 0.f);
    } else {
      slots.emplace_back(anchors[b].frame, out);
    }
  }
  LoadInto(slots);
}

std::vector<FrameRef> FrameSampler::BatchRefs(int64_t step, int batch_size) const {
  std::vector<FrameRef> refs(static_cast<size_t>(batch_size));
  for (int b = 0; b < batch_size; ++b) {
    const uint64_t key = SlotKey(seed_, step, b);
    const double u = static_cast<double>(MixBits(key + 1) >> 11) * 0x1.0p-53;  // [0, 1)
    FrameRef& r = refs[b];
    while (r.dataset + 1 < weights_prefix_.size() && u >= weights_prefix_[r.dataset]) ++r.dataset;
    const shard::DatasetReader& reader = *readers_[r.dataset];
    // `x % n` has a bias below n / 2^64: negligible, and identical on every platform.
    r.episode = MixBits(key + 2) % reader.num_episodes();
    const auto [shard, local] = reader.Locate(r.episode);
    r.step = MixBits(key + 3) % reader.shard(shard).entries()[local].num_steps;
  }
  return refs;
}

std::vector<std::vector<FrameRef>> FrameSampler::EpisodeRefs(size_t max_episodes) const {
  std::vector<std::vector<FrameRef>> out;
  for (size_t d = 0; d < readers_.size(); ++d) {
    const shard::DatasetReader& reader = *readers_[d];
    for (size_t e = 0; e < reader.num_episodes() && out.size() < max_episodes; ++e) {
      const auto [shard, local] = reader.Locate(e);
      std::vector<FrameRef>& clip = out.emplace_back();
      for (size_t t = 0; t < reader.shard(shard).entries()[local].num_steps; ++t)
        clip.push_back({d, e, t});
    }
  }
  return out;
}

void FrameSampler::Load(const std::vector<FrameRef>& refs, float* out) const {
  Load(refs, {}, out, nullptr);
}

void FrameSampler::LoadInto(const std::vector<std::pair<FrameRef, float*>>& slots) const {
  std::vector<bool> done(slots.size(), false);
  for (size_t i = 0; i < slots.size(); ++i) {
    if (done[i]) continue;
    const FrameRef& first = slots[i].first;
    const shard::DatasetReader& reader = *readers_[first.dataset];
    const size_t k = first.episode;
    Episode episode = reader.ReadEpisode(k);
    auto it = episode.images.find(image_key_);
    Check(it != episode.images.end() && !it->second.frames.empty(),
          "episode has no image stream '" + image_key_ + "'",
          {.file = reader.dir(), .record = static_cast<int64_t>(k), .record_label = "episode"});
    for (size_t j = i; j < slots.size(); ++j) {  // every slot drawn from this episode
      const FrameRef& ref = slots[j].first;
      if (done[j] || ref.dataset != first.dataset || ref.episode != k) continue;
      try {
        DecodeFrame(it->second.frames.at(ref.step), size_, slots[j].second);
      } catch (const Error& e) {
        throw e.WithFile(reader.dir()).WithRecord(static_cast<int64_t>(k), "episode");
      }
      done[j] = true;
    }
  }
}

std::vector<std::string> FrameSampler::dataset_names() const {
  std::vector<std::string> names;
  for (const auto& r : readers_) names.push_back(r->index().dataset);
  return names;
}

std::vector<double> FrameSampler::step_counts() const {
  std::vector<double> counts;
  for (const auto& r : readers_) counts.push_back(static_cast<double>(r->index().num_steps));
  return counts;
}

nlohmann::json FrameSampler::DataProvenance() const {
  nlohmann::json out = nlohmann::json::array();
  for (size_t d = 0; d < readers_.size(); ++d) {
    const auto& index = readers_[d]->index();
    nlohmann::json shards = nlohmann::json::array();
    for (const auto& s : index.shards) shards.push_back({{"file", s.file}, {"sha256", s.sha256}});
    out.push_back({{"dataset", index.dataset},
                   {"split", index.split},
                   {"weight", weights_prefix_[d] - (d ? weights_prefix_[d - 1] : 0.0)},
                   {"index_config_hash", index.provenance.value("config_hash", "")},
                   {"num_steps", index.num_steps},
                   {"shards", shards}});
  }
  return out;
}

}  // namespace wm::tokenize

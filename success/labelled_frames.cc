#include "success/labelled_frames.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "core/episode.h"
#include "core/error.h"
#include "core/mix_bits.h"
#include "core/shard/dataset_reader.h"
#include "metrics/value/correlation.h"
#include "trainkit/frame_decode.h"

namespace wm::success {

LabelledFrames::LabelledFrames(const std::string& dir, std::string image_key, int size,
                               double reward_threshold, bool need_both)
    : size_(size) {
  const shard::DatasetReader reader(dir);
  for (size_t k = 0; k < reader.num_episodes(); ++k) {
    Episode e = reader.ReadEpisode(k);
    auto images = e.images.find(image_key);
    Check(images != e.images.end(), "episode has no image stream '" + image_key + "'",
          {.file = dir,
           .record = static_cast<int64_t>(k),
           .record_label = "episode",
           .key = "data.image_key"});
    for (int64_t t = 0; t < e.num_steps; ++t) {
      const bool success = e.rewards.at(static_cast<size_t>(t)) > reward_threshold;
      (success ? positives_ : negatives_).push_back(static_cast<uint32_t>(all_.size()));
      all_.push_back({static_cast<int32_t>(k), static_cast<int32_t>(t), success});
    }
    frames_.push_back(std::move(images->second.frames));
    policy_ids_.push_back(e.policy_id);
  }
  Check(!all_.empty(), "the dataset has no frames", {.file = dir});
  Check(!need_both || (!positives_.empty() && !negatives_.empty()),
        "the dataset has " + std::to_string(positives_.size()) + " success frames (reward > " +
            std::to_string(reward_threshold) + ") and " + std::to_string(negatives_.size()) +
            " others; a success classifier needs both",
        {.file = dir, .key = "data.reward_threshold"});
  const shard::DatasetIndex& index = reader.index();
  nlohmann::json shards = nlohmann::json::array();
  for (const auto& s : index.shards) shards.push_back({{"file", s.file}, {"sha256", s.sha256}});
  provenance_ = {{"dataset", index.dataset},
                 {"split", index.split},
                 {"index_config_hash", index.provenance.value("config_hash", "")},
                 {"num_episodes", index.num_episodes},
                 {"num_steps", index.num_steps},
                 {"shards", shards}};
}

std::vector<FrameRef> LabelledFrames::Draw(uint64_t seed, int64_t step, int batch,
                                           double positive_fraction) const {
  std::mt19937_64 rng(MixBits(seed ^ MixBits(static_cast<uint64_t>(step))));
  const auto wanted = static_cast<int>(std::lround(batch * positive_fraction));
  std::vector<FrameRef> refs;
  for (int b = 0; b < batch; ++b) {
    const std::vector<uint32_t>& pool = b < wanted ? positives_ : negatives_;
    refs.push_back(all_[pool[rng() % pool.size()]]);  // bias < 2^-40 at these counts
  }
  return refs;
}

void LabelledFrames::Load(const std::vector<FrameRef>& refs, float* frames, float* labels) const {
  const size_t frame_floats = 3ull * size_ * size_;
  for (size_t b = 0; b < refs.size(); ++b) {
    trainkit::DecodeFrame(
        frames_.at(static_cast<size_t>(refs[b].episode)).at(static_cast<size_t>(refs[b].step)),
        size_, frames + b * frame_floats);
    labels[b] = refs[b].success ? 1.0f : 0.0f;
  }
}

double Auroc(const std::vector<float>& scores, const std::vector<float>& labels) {
  std::vector<bool> positive;
  positive.reserve(labels.size());
  for (float label : labels) positive.push_back(label > 0.5f);
  return metrics::Auroc(std::vector<double>(scores.begin(), scores.end()), positive);
}

}  // namespace wm::success

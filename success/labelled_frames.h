#pragma once
// The frames of a shard dataset labelled success / not success by the reward logged with them
// (RLDS logs reward_t with observation o_t; tabletop's is 1 on the step whose frame shows the
// block in the goal: docs/success.md, "Labels"). Batches are balanced: a fixed share of success
// frames, each class drawn uniformly, a pure function of (seed, step) through a std::mt19937_64
// seeded with MixBits(seed, step), so a resumed run draws exactly the frames of an uninterrupted
// one. Episodes are kept encoded; only the sampled frames are decoded. Torch-free.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace wm::success {

struct FrameRef {
  int32_t episode = 0, step = 0;
  bool success = false;
};

class LabelledFrames {
 public:
  // Throws wm::Error naming `dir` when the dataset has no frames of one of the two classes and
  // `need_both` is set (training), or no frames at all.
  LabelledFrames(const std::string& dir, std::string image_key, int size, double reward_threshold,
                 bool need_both);

  // `batch` frames, round(batch * positive_fraction) success frames first.
  std::vector<FrameRef> Draw(uint64_t seed, int64_t step, int batch,
                             double positive_fraction) const;
  // frames [B, 3, S, S] in [-1, 1]; labels [B] 0/1.
  void Load(const std::vector<FrameRef>& refs, float* frames, float* labels) const;

  const std::vector<FrameRef>& all() const { return all_; }  // every frame, episode-major
  int64_t positives() const { return static_cast<int64_t>(positives_.size()); }
  int64_t negatives() const { return static_cast<int64_t>(negatives_.size()); }
  int64_t num_episodes() const { return static_cast<int64_t>(frames_.size()); }
  const std::string& policy_id(int64_t episode) const {
    return policy_ids_.at(static_cast<size_t>(episode));
  }
  // {"dataset", "split", "index_config_hash", "num_episodes", "num_steps", "shards": [{"file",
  // "sha256"}]}; no paths, so manifests do not depend on where data lives.
  const nlohmann::json& provenance() const { return provenance_; }

 private:
  int size_;
  std::vector<std::vector<std::string>> frames_;  // [episode][step]: encoded image
  std::vector<std::string> policy_ids_;           // [episode], "" when unknown
  std::vector<FrameRef> all_;
  std::vector<uint32_t> positives_, negatives_;  // indices into all_
  nlohmann::json provenance_;
};

// Area under the ROC curve of `scores` for `labels` (1 = positive): the probability that a random
// positive scores above a random negative, ties counted half. NaN without both classes
// (metrics::Auroc on the same numbers).
double Auroc(const std::vector<float>& scores, const std::vector<float>& labels);

}  // namespace wm::success

#include "train/segment_sampler.h"

#include <algorithm>
#include <filesystem>
#include <random>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/sha256.h"
#include "core/tokens/token_dataset.h"
#include "trainkit/mixture.h"

namespace wm::train {
uint64_t MixSeed(uint64_t seed, uint64_t counter) {
  uint64_t z = seed + 0x9E3779B97F4A7C15ull * (counter + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

struct SegmentSampler::Source {
  std::unique_ptr<tokens::TokenDataset> data;
  ActionNorm norm;
  std::string index_sha256;
  std::vector<int64_t> episodes;        // episodes with >= context_frames frames
  std::vector<uint64_t> window_prefix;  // cumulative segment counts over `episodes`
  double weight = 0;
};

SegmentSampler::SegmentSampler(const std::vector<std::string>& dirs, int context_frames,
                               const std::string& mixture_file, int64_t action_dim)
    : context_frames_(context_frames) {
  Check(!dirs.empty(), "no token datasets given (--tokens)");
  std::vector<double> sizes;
  std::vector<std::string> names;
  for (const std::string& dir : dirs) {
    auto s = std::make_unique<Source>();
    s->data = std::make_unique<tokens::TokenDataset>(dir);
    const tokens::TokenIndex& index = s->data->index();
    s->index_sha256 = Sha256File((std::filesystem::path(dir) / "index.json").string());
    s->norm.mean.assign(index.action_stats.mean.begin(), index.action_stats.mean.end());
    s->norm.std.assign(index.action_stats.std.begin(), index.action_stats.std.end());
    uint64_t total = 0;
    for (int64_t k = 0; k < s->data->num_episodes(); ++k) {
      const int64_t frames = s->data->episode(k).num_frames;
      if (frames < context_frames) continue;
      s->episodes.push_back(k);
      total += static_cast<uint64_t>(frames - context_frames + 1);
      s->window_prefix.push_back(total);
    }
    Check(total > 0,
          "no episode has model.context_frames = " + std::to_string(context_frames) + " frames",
          {.file = dir});
    if (!sources_.empty()) {
      const auto& first = sources_.front()->data->index().tokenizer;
      Check(index.tokenizer.checkpoint_sha256 == first.checkpoint_sha256,
            "token datasets come from different tokenizer checkpoints", {.file = dir});
    }
    sizes.push_back(static_cast<double>(total));
    names.push_back(index.dataset);
    sources_.push_back(std::move(s));
  }
  SetActionWidth(action_dim);
  const std::vector<double> weights = trainkit::MixtureWeights(
      mixture_file.empty() ? std::map<std::string, double>{} : trainkit::LoadMixture(mixture_file),
      mixture_file, names, sizes);
  for (size_t i = 0; i < sources_.size(); ++i) sources_[i]->weight = weights[i];
  double sum = 0;
  for (double w : weights) sum += w;
  Check(sum > 0, "mixture weights of the given datasets sum to 0", {.key = "data.mixture"});
  double acc = 0;
  for (double w : weights) cumulative_weight_.push_back((acc += w) / sum);
  cumulative_weight_.back() = 1.0;
}

SegmentSampler::~SegmentSampler() = default;

void SegmentSampler::SetActionWidth(int64_t requested) {
  int64_t widest = 0;
  for (const auto& s : sources_) widest = std::max(widest, s->norm.dim());
  action_dim_ = requested > 0 ? requested : widest;
  for (const auto& s : sources_) {
    Check(s->norm.dim() <= action_dim_,
          "actions have " + std::to_string(s->norm.dim()) + " values, the model takes " +
              std::to_string(action_dim_),
          {.file = s->data->dir(), .key = "action_dim"});
    mixed_widths_ = mixed_widths_ || s->norm.dim() < action_dim_;
  }
}

std::vector<SegmentRef> SegmentSampler::Draw(uint64_t seed, int64_t step, int batch) const {
  std::mt19937_64 rng(MixSeed(seed, static_cast<uint64_t>(step)));
  std::vector<SegmentRef> refs(batch);
  for (SegmentRef& r : refs) {
    const double u = static_cast<double>(rng() >> 11) * 0x1.0p-53;  // [0, 1)
    r.dataset =
        static_cast<int>(std::upper_bound(cumulative_weight_.begin(), cumulative_weight_.end(), u) -
                         cumulative_weight_.begin());
    r.dataset = std::min<int>(r.dataset, static_cast<int>(sources_.size()) - 1);
    const Source& s = *sources_[r.dataset];
    const uint64_t w = rng() % s.window_prefix.back();
    const size_t e = std::upper_bound(s.window_prefix.begin(), s.window_prefix.end(), w) -
                     s.window_prefix.begin();
    r.episode = s.episodes[e];
    r.start = static_cast<int64_t>(w - (e == 0 ? 0 : s.window_prefix[e - 1]));
  }
  return refs;
}

void SegmentSampler::Fill(const std::vector<SegmentRef>& refs, size_t first, size_t count,
                          SegmentData& out) const {
  const int64_t T = context_frames_, N = tokens_per_frame();
  out.batch = static_cast<int64_t>(count);
  out.tokens.resize(count * T * N);
  const int64_t D = action_dim_;
  out.actions.assign(count * T * D, 0.f);  // a narrower dataset's padding stays 0
  out.action_mask.assign(mixed_widths_ ? count * D : 0, 0.f);
  out.rewards.resize(count * T);
  out.terminals.resize(count * T);
  for (size_t b = 0; b < count; ++b) {
    const SegmentRef& r = refs[first + b];
    const Source& s = *sources_[r.dataset];
    s.data->CopyTokens(r.episode, r.start, T, out.tokens.data() + b * T * N);
    s.norm.Apply(s.data->actions(r.episode) + r.start * s.norm.dim(),
                 out.actions.data() + b * T * D, T, D);
    if (mixed_widths_) std::fill_n(out.action_mask.begin() + b * D, s.norm.dim(), 1.f);
    const float* rewards = s.data->rewards(r.episode) + r.start;
    const uint8_t* terminal = s.data->is_terminal(r.episode) + r.start;
    for (int64_t t = 0; t < T; ++t) {
      out.rewards[b * T + t] = rewards[t];
      out.terminals[b * T + t] = terminal[t] ? 1.f : 0.f;
    }
  }
}

int64_t SegmentSampler::tokens_per_frame() const {
  return sources_.front()->data->tokens_per_frame();
}
int64_t SegmentSampler::num_codes() const {
  return sources_.front()->data->index().tokenizer.num_codes;
}
int SegmentSampler::grid_h() const { return sources_.front()->data->index().tokenizer.grid_h; }
int SegmentSampler::grid_w() const { return sources_.front()->data->index().tokenizer.grid_w; }
int SegmentSampler::levels() const { return sources_.front()->data->index().tokenizer.levels; }
int64_t SegmentSampler::action_dim() const { return action_dim_; }

nlohmann::json SegmentSampler::ActionNorms() const {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& s : sources_) out[s->data->index().dataset] = s->norm.ToJson();
  return out;
}

nlohmann::json SegmentSampler::DataProvenance() const {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& s : sources_) {
    const tokens::TokenIndex& index = s->data->index();
    out.push_back({{"dataset", index.dataset},
                   {"split", index.split},
                   {"index_sha256", s->index_sha256},
                   {"tokenizer_checkpoint_sha256", index.tokenizer.checkpoint_sha256},
                   {"tokenizer_config_hash", index.tokenizer.config_hash},
                   {"num_episodes", s->data->num_episodes()},
                   {"num_frames", index.num_frames},
                   {"weight", s->weight}});
  }
  return out;
}

}  // namespace wm::train

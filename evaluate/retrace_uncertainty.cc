#include "evaluate/retrace_uncertainty.h"

#include <algorithm>
#include <set>

#include "core/error.h"
#include "core/tokens/token_dataset.h"
#include "evaluate/clip_decode.h"
#include "tokenize/tokenizer.h"
#include "train/dynamics_model.h"

namespace wm::evaluate {
namespace {

double Mean(const std::vector<float>& v) {
  double s = 0;
  for (float x : v) s += x;
  return v.empty() ? 0 : s / static_cast<double>(v.size());
}

// One episode: step t's variants from sample 0's frames 0..t, and the plain step's entropy.
RetraceVariants EpisodeVariants(const train::DynamicsModel& model, const float* actions,
                                int64_t dim, const EpisodeRollout& r,
                                const std::vector<float>& policy_z, const std::vector<int64_t>& ks,
                                const RolloutOptions& o) {
  RetraceVariants v{.kinds = static_cast<int64_t>(ks.size())};
  const std::vector<int64_t>& frames = r.tokens[0];
  for (int64_t t = 0; t < r.steps; ++t) {
    const uint64_t seed = ImaginationSeed(o.seed, r.episode, 0, t);
    std::vector<float> entropy;  // [N]
    model.PredictNextFrame(ImaginationContext(model, frames, r.contexts[t], policy_z, seed), 0,
                           o.decode_steps, o.temperature, &entropy);
    v.token_entropy.push_back(Mean(entropy));
    std::vector<int64_t>& step = v.frames.emplace_back();
    for (int64_t k : ks) {
      const auto slots = AnchoredContext(actions, dim, t, k);
      const auto next =
          model.PredictNextFrame(ImaginationContext(model, frames, slots, policy_z, seed), 0,
                                 o.decode_steps, o.temperature);
      step.insert(step.end(), next.begin(), next.end());
    }
  }
  return v;
}

}  // namespace

void CheckRetraceKs(const std::vector<int64_t>& ks, int64_t context) {
  const std::set<int64_t> distinct(ks.begin(), ks.end());
  Check(distinct.size() >= 2 && distinct.size() == ks.size(),
        "--retrace-ks needs at least two distinct kept-frame counts", {.key = "--retrace-ks"});
  Check(*distinct.begin() >= 0 && *distinct.rbegin() <= context - 1,
        "--retrace-ks values must be in [0, " + std::to_string(context - 1) +
            "] (context frames - 1: the real frame 0 takes a slot)",
        {.key = "--retrace-ks"});
}

std::vector<RetraceVariants> ImagineRetraceVariants(const train::DynamicsModel& model,
                                                    const tokens::TokenDataset& data,
                                                    const std::vector<EpisodeRollout>& plain,
                                                    const std::vector<int64_t>& ks,
                                                    const RolloutOptions& o) {
  CheckRetraceKs(ks, ContextFrames(model, o.context));
  CheckRolloutModeFits(RolloutMode::kRetrace, data);
  std::vector<int64_t> episodes;
  episodes.reserve(plain.size());
  for (const EpisodeRollout& r : plain) episodes.push_back(r.episode);
  const auto z = PolicyEmbeddings(model, data, episodes, o.policy_prefix);
  std::vector<RetraceVariants> out;
  for (size_t i = 0; i < plain.size(); ++i) {
    out.push_back(EpisodeVariants(model, data.actions(plain[i].episode), data.action_dim(),
                                  plain[i], z[i], ks, o));
  }
  return out;
}

std::vector<std::pair<int64_t, int64_t>> VariantPairs(int64_t kinds) {
  std::vector<std::pair<int64_t, int64_t>> pairs;
  for (int64_t i = 0; i < kinds; ++i) {
    for (int64_t j = i + 1; j < kinds; ++j) pairs.emplace_back(i, j);
  }
  return pairs;
}

std::vector<double> VariantDisagreement(const tokenize::Tokenizer& tok, const RetraceVariants& v,
                                        const Clip& given) {
  const auto steps = static_cast<int64_t>(v.frames.size());
  std::vector<int64_t> all;  // [steps * kinds, N]: every variant of every step
  for (const auto& step : v.frames) all.insert(all.end(), step.begin(), step.end());
  const Clip decoded = DecodeClip(tok, all, 0, steps * v.kinds, given);
  const auto pairs = VariantPairs(v.kinds);
  const int64_t floats = 3 * int64_t{decoded.size} * decoded.size;
  std::vector<float> a, b;  // the pairs of every step, [steps * pairs, 3, S, S] each
  for (int64_t t = 0; t < steps; ++t) {
    for (const auto& [i, j] : pairs) {
      const float* fi = decoded.frame(t * v.kinds + i);
      const float* fj = decoded.frame(t * v.kinds + j);
      a.insert(a.end(), fi, fi + floats);
      b.insert(b.end(), fj, fj + floats);
    }
  }
  const auto n = static_cast<int64_t>(pairs.size());
  const std::vector<double> d = tok.PerceptualDistance(a.data(), b.data(), steps * n);
  std::vector<double> out;
  for (int64_t t = 0; t < steps; ++t) {
    double sum = 0;
    for (int64_t p = 0; p < n; ++p) sum += d[t * n + p];
    out.push_back(sum / static_cast<double>(n));
  }
  return out;
}

}  // namespace wm::evaluate

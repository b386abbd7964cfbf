#pragma once
// Uncertainty without ensembles (WHALE section 3.4's retracing rollout, issue 21 item 6), for
// wm-eval --retrace-ks. For each imagined step t of sample 0's plain rollout, frame t+1 is
// imagined again from AnchoredContext (evaluate/retrace.h) with each kept count k: the real
// frame 0, the newest k imagined frames, the older steps folded into one retrace action. Every
// variant uses the plain step's own sampling seed, so they differ only in how much of the
// imagined past they see. Their disagreement in the tokenizer's feature space, and the
// predictive entropy of the plain step's token distributions, are per-step uncertainty signals
// that the report sets against the real error (evaluate/uncertainty_report.h).
#include <cstdint>
#include <utility>
#include <vector>

#include "evaluate/frame_scores.h"
#include "evaluate/rollout.h"

namespace wm::tokenize {
class Tokenizer;
}

namespace wm::evaluate {

// One episode's variants and entropies; step t (0-based) imagines frame t+1.
struct RetraceVariants {
  int64_t kinds = 0;                         // variants per step: the number of k
  std::vector<std::vector<int64_t>> frames;  // per step: [kinds * N] tokens, in --retrace-ks order
  std::vector<double> token_entropy;         // per step: mean over its N tokens (nats)
};

// Throws wm::Error unless `ks` holds at least two distinct kept counts, each in [0, context - 1]
// (`context`: the context frames the rollout gives the model).
void CheckRetraceKs(const std::vector<int64_t>& ks, int64_t context);

// The variants of every step of each rollout in `plain` (a plain Rollout with `options`, sample
// 0; its contexts tell the plain step), and the entropy of the plain step's token distributions
// (DynamicsModel::PredictNextFrame's token_entropy). Deterministic on CPU, like Rollout.
std::vector<RetraceVariants> ImagineRetraceVariants(const train::DynamicsModel& model,
                                                    const tokens::TokenDataset& data,
                                                    const std::vector<EpisodeRollout>& plain,
                                                    const std::vector<int64_t>& ks,
                                                    const RolloutOptions& options);

// Per step: the mean over the pairs of variants of lpips_style (Tokenizer::PerceptualDistance:
// the distance between their decoded frames in the tokenizer's encoder features); 0 where every
// variant imagines the same tokens. `given`: the real frame 0 (anchored tokenizers decode with it).
std::vector<double> VariantDisagreement(const tokenize::Tokenizer& tok, const RetraceVariants& v,
                                        const Clip& given);

// The pairs (i, j), i < j, of `kinds` variants, in the order (0,1), (0,2), ..., (1,2), ...
std::vector<std::pair<int64_t, int64_t>> VariantPairs(int64_t kinds);

}  // namespace wm::evaluate

#pragma once
// Frames as the reports score and show them: real frames from a shard episode, and token frames
// decoded by the tokenizer (an anchored tokenizer with the episode's real start frame), shared by
// the open-loop rollouts (evaluator.cc) and the closed-loop policy evaluation (policy_eval.cc).
#include <cstdint>
#include <string>
#include <vector>

#include "evaluate/frame_scores.h"

namespace wm {
struct Episode;
}
namespace wm::tokenize {
class Tokenizer;
}

namespace wm::evaluate {

// Frames 0..frames-1 of `ep`'s image stream `image_key`, decoded and resized to `size`.
Clip RealClip(const Episode& ep, const std::string& image_key, int size, int64_t frames);

// Frames first..first+count-1 of `tokens` ([frames, N]), decoded. An anchored tokenizer decodes
// them all with `given`'s last frame, the real frame the rollout started from: what a user of
// the model has.
Clip DecodeClip(const tokenize::Tokenizer& tok, const std::vector<int64_t>& tokens, int64_t first,
                int64_t count, const Clip& given);

}  // namespace wm::evaluate

// token_dataset_tool: writes a synthetic token dataset with the C++ writer and prints, as JSON,
// what it wrote and what the C++ reader returns, so tests/python/test_wmshard_tokens.py can
// cross-check scripts/wmshard.py (an independent reader written from docs/token-format.md).
//
//   token_dataset_tool DIR EPISODES PARTS GRID_H GRID_W NUM_CODES SEED [ACTION_DIM [LEVELS]]
//
// stdout: {"token_dtype", "num_parts", "episodes": [{"tokens" [F][h][w] (with LEVELS > 1:
//          [F][levels][h][w]) as written,
//          "tokens_read" (the same, through TokenDataset::CopyTokens), "actions" [F][D],
//          "rewards", "discounts", "is_first", "is_last", "is_terminal", "part",
//          "frame_offset", "num_frames", "source_episode", "episode_key", "policy_id",
//          "language_instruction", "episode_seed"}]}
// Exit codes: 0 ok, 1 a wm::Error (one line on stderr), 2 bad arguments.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/tokens/token_dataset.h"
#include "tests/core/test_util.h"

namespace {
using nlohmann::json;

// C-order values from flat[*at] on -> nested lists of `shape` (from dimension `d`).
template <typename T>
json Nest(const std::vector<T>& flat, const std::vector<int64_t>& shape, size_t d, size_t* at) {
  json out = json::array();
  for (int64_t i = 0; i < shape[d]; ++i) {
    out.push_back(d + 1 == shape.size() ? json(flat[(*at)++]) : Nest(flat, shape, d + 1, at));
  }
  return out;
}

// An episode's flat tokens -> [F][h][w], or [F][levels][h][w].
template <typename T>
json Tokens(const std::vector<T>& flat, const wm::tokens::TokenizerInfo& t, int64_t frames) {
  size_t at = 0;
  return Nest(flat, wm::tokens::TokenSectionShape(t, frames), 0, &at);
}

template <typename T>
json Array(const T* p, int64_t n) {
  return json(std::vector<T>(p, p + n));
}

json EpisodeJson(const wm::tokens::TokenDataset& d, int64_t k,
                 const std::vector<uint32_t>& written) {
  const wm::tokens::TokenEpisode& e = d.episode(k);
  const auto& t = d.index().tokenizer;
  std::vector<int64_t> read(static_cast<size_t>(e.num_frames * d.tokens_per_frame()));
  d.CopyTokens(k, 0, e.num_frames, read.data());
  json actions = json::array();
  for (int64_t f = 0; f < e.num_frames; ++f) {
    actions.push_back(Array(d.actions(k) + f * d.action_dim(), d.action_dim()));
  }
  return {{"tokens", Tokens(written, t, e.num_frames)},
          {"tokens_read", Tokens(read, t, e.num_frames)},
          {"actions", actions},
          {"rewards", Array(d.rewards(k), e.num_frames)},
          {"discounts", Array(d.discounts(k), e.num_frames)},
          {"is_first", Array(d.is_first(k), e.num_frames)},
          {"is_last", Array(d.is_last(k), e.num_frames)},
          {"is_terminal", Array(d.is_terminal(k), e.num_frames)},
          {"part", e.part},
          {"frame_offset", e.frame_offset},
          {"num_frames", e.num_frames},
          {"source_episode", e.source_episode},
          {"episode_key", e.episode_key},
          {"policy_id", e.policy_id},
          {"language_instruction", e.language_instruction},
          {"episode_seed", e.episode_seed ? json(*e.episode_seed) : json(nullptr)}};
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 8 || argc > 10) {
    std::fprintf(stderr,
                 "usage: token_dataset_tool DIR EPISODES PARTS GRID_H GRID_W NUM_CODES SEED "
                 "[ACTION_DIM [LEVELS]]\n"
                 "example: token_dataset_tool /tmp/tok 5 3 2 3 1024 7\n");
    return 2;
  }
  try {
    const std::string dir = argv[1];
    const int episodes = std::stoi(argv[2]), parts = std::stoi(argv[3]);
    const int grid_h = std::stoi(argv[4]), grid_w = std::stoi(argv[5]);
    const int64_t num_codes = std::stoll(argv[6]);
    const uint64_t seed = std::stoull(argv[7]);
    const int64_t action_dim = argc >= 9 ? std::stoll(argv[8]) : wm::kActionDim;
    const int levels = argc == 10 ? std::stoi(argv[9]) : 1;
    std::filesystem::create_directories(dir);  // the part writer expects an existing directory
    auto written = wm::test::MakeTokenDataset(dir, episodes, parts, grid_h, grid_w, num_codes, seed,
                                              action_dim, levels);
    wm::tokens::TokenDataset d(dir);
    json out = {{"token_dtype", d.index().token_dtype},
                {"num_parts", d.index().num_parts},
                {"episodes", json::array()}};
    for (int64_t k = 0; k < d.num_episodes(); ++k) {
      out["episodes"].push_back(EpisodeJson(d, k, written[static_cast<size_t>(k)]));
    }
    std::cout << out.dump() << "\n";
  } catch (const wm::Error& e) {
    std::fprintf(stderr, "token_dataset_tool: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {  // std::stoi on a bad argument
    std::fprintf(stderr, "token_dataset_tool: bad argument: %s\n", e.what());
    return 2;
  }
  return 0;
}

#include "ingest/episode_json.h"

#include "core/sha256.h"

namespace wm::ingest {

nlohmann::json EpisodeToJson(const Episode& e) {
  using nlohmann::json;
  json actions = json::array();
  for (int64_t t = 0; t < e.num_steps; ++t) {
    auto row = e.actions.begin() + t * e.action_dim;
    actions.push_back(std::vector<double>(row, row + e.action_dim));
  }
  const EncodedFrames& image = e.images.at("image");
  json hashes = json::array(), num_frames = json::object();
  for (const auto& f : image.frames) hashes.push_back(Sha256Hex(f));
  for (const auto& [name, frames] : e.images) num_frames[name] = frames.frames.size();
  return {{"episode_key", e.episode_key},
          {"num_steps", e.num_steps},
          {"actions", actions},
          {"rewards", std::vector<double>(e.rewards.begin(), e.rewards.end())},
          {"discounts", std::vector<double>(e.discounts.begin(), e.discounts.end())},
          {"is_first", std::vector<int>(e.is_first.begin(), e.is_first.end())},
          {"is_last", std::vector<int>(e.is_last.begin(), e.is_last.end())},
          {"is_terminal", std::vector<int>(e.is_terminal.begin(), e.is_terminal.end())},
          {"language_instruction", e.language_instruction},
          {"policy_id", e.policy_id},
          {"episode_seed", e.episode_seed ? json(*e.episode_seed) : json(nullptr)},
          {"image_shape", {image.height, image.width, image.channels}},
          {"num_frames", num_frames},
          {"image_sha256", hashes}};
}

}  // namespace wm::ingest

#pragma once
// How one RLDS dataset's features map onto the canonical episode: which key is the camera,
// how the action is assembled (the canonical 7-dim one, or another width and space), where reward,
// flags and instruction live. One YAML file
// per dataset in configs/datasets/ (documented in docs/dataset-mapping.md).
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace wm::rlds {

struct ActionPart {
  std::string key;          // per-step tensor feature; empty for a zero fill
  std::vector<int> select;  // indices taken from the feature's per-step vector (all if empty)
  int zeros = 0;            // when `key` is empty: this many zero dimensions
  double scale = 1.0, offset = 0.0;  // value * scale + offset (e.g. open -> closed: -1, +1)
  int Width(int feature_size) const;
};

struct DatasetMapping {
  std::string file;  // where it was loaded from
  std::string dataset;
  std::string image;  // required
  std::optional<std::string> depth, segmentation;
  std::vector<ActionPart> action;  // widths sum to 7 for eef_delta, else to 1..kMaxActionDim
  std::string action_space = "eef_delta";       // eef_delta, joint_position or other
  std::optional<std::string> reward, discount;  // zeros / ones when absent
  std::string is_first = "steps/is_first", is_last = "steps/is_last",
              is_terminal = "steps/is_terminal";
  std::optional<std::string> language_instruction, policy_id, episode_seed;
  nlohmann::json ToJson() const;  // for the config hash
};

DatasetMapping LoadDatasetMapping(const std::string& yaml_file);
// `<configs_dir>/datasets/<dataset>.yaml`; throws listing the available mappings if absent.
std::string FindMappingFile(const std::string& configs_dir, const std::string& dataset);

}  // namespace wm::rlds

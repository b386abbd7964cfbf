#pragma once
// Which LeRobot feature is which: the camera, the action and its space, the per-step index
// columns, optional reward and termination. Real datasets rename keys (`actions`, `state`,
// `image`), so a small YAML file decides (docs/lerobot-mapping.md, schemas/lerobot-mapping
// .schema.json). configs/lerobot/default.yaml holds LeRobot's own names.
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

namespace wm::ingest {

struct LeRobotMapping {
  std::string file;    // where it was loaded from
  std::string camera;  // video feature key; empty: the dataset's only video feature
  std::string action = "action";
  std::string action_space = "other";  // "eef_delta", "joint_position" or "other"
  std::optional<std::string> state = "observation.state";  // read and checked when present
  std::string timestamp = "timestamp", frame_index = "frame_index", episode_index = "episode_index",
              task_index = "task_index";
  std::optional<std::string> reward, is_terminal;  // e.g. next.reward, next.done
  // |parquet timestamp - video frame time| must be below this; LeRobotDataset's default
  // tolerance_s (lerobot/datasets/lerobot_dataset.py) is 1e-4 s.
  double tolerance_s = 1e-4;
  nlohmann::json ToJson() const;  // for the config hash
};

LeRobotMapping LoadLeRobotMapping(const std::string& yaml_file);
// `--mapping` when given; else `<configs>/lerobot/<dataset>.yaml` when it exists; else
// `<configs>/lerobot/default.yaml`.
std::string FindLeRobotMapping(const std::string& mapping, const std::string& configs_dir,
                               const std::string& dataset);

}  // namespace wm::ingest

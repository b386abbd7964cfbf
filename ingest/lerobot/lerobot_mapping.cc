#include "ingest/lerobot/lerobot_mapping.h"

#include <yaml-cpp/yaml.h>

#include <filesystem>

#include "core/error.h"
#include "core/sectioned_yaml.h"
#include "core/shard/dataset_index.h"

namespace wm::ingest {
namespace fs = std::filesystem;

nlohmann::json LeRobotMapping::ToJson() const {
  auto opt = [](const std::optional<std::string>& s) {
    return s ? nlohmann::json(*s) : nlohmann::json(nullptr);
  };
  return {{"camera", camera},
          {"action", action},
          {"action_space", action_space},
          {"state", opt(state)},
          {"timestamp", timestamp},
          {"frame_index", frame_index},
          {"episode_index", episode_index},
          {"task_index", task_index},
          {"reward", opt(reward)},
          {"is_terminal", opt(is_terminal)},
          {"tolerance_s", tolerance_s}};
}

LeRobotMapping LoadLeRobotMapping(const std::string& file) {
  LeRobotMapping m;
  m.file = file;
  std::string key;
  try {
    YAML::Node y = YAML::LoadFile(file);
    CheckKnownYamlKeys(y,
                       {"camera", "action", "action_space", "state", "timestamp", "frame_index",
                        "episode_index", "task_index", "reward", "is_terminal", "tolerance_s"},
                       file);
    // A key absent keeps its default; `null` clears an optional one.
    auto text = [&](const char* k, std::string& out) {
      key = k;
      if (y[k] && !y[k].IsNull()) out = y[k].as<std::string>();
    };
    auto optional = [&](const char* k, std::optional<std::string>& out) {
      key = k;
      if (!y[k]) return;
      out = y[k].IsNull() ? std::nullopt : std::optional(y[k].as<std::string>());
    };
    text("camera", m.camera);
    text("action", m.action);
    text("action_space", m.action_space);
    Check(shard::IsKnownActionSpace(m.action_space),
          "must be eef_delta, joint_position or other, got '" + m.action_space + "'");
    optional("state", m.state);
    text("timestamp", m.timestamp);
    text("frame_index", m.frame_index);
    text("episode_index", m.episode_index);
    text("task_index", m.task_index);
    optional("reward", m.reward);
    optional("is_terminal", m.is_terminal);
    key = "tolerance_s";
    if (y[key]) m.tolerance_s = y[key].as<double>();
    Check(m.tolerance_s > 0 && m.tolerance_s < 1, "must be in (0, 1) seconds");
  } catch (const YAML::Exception& e) {
    throw Error(std::string("invalid LeRobot mapping: ") + e.what(), {.file = file, .key = key});
  } catch (const Error& e) {
    throw e.WithKey(key).WithFile(file);
  }
  return m;
}

std::string FindLeRobotMapping(const std::string& mapping, const std::string& configs_dir,
                               const std::string& dataset) {
  if (!mapping.empty()) return mapping;
  const fs::path dir = fs::path(configs_dir) / "lerobot";
  if (fs::exists(dir / (dataset + ".yaml"))) return (dir / (dataset + ".yaml")).string();
  const fs::path fallback = dir / "default.yaml";
  Check(fs::exists(fallback),
        "no LeRobot mapping: neither " + dataset +
            ".yaml nor default.yaml exists (pass --mapping FILE)",
        {.file = dir.string()});
  return fallback.string();
}

}  // namespace wm::ingest

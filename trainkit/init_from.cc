#include "trainkit/init_from.h"

#include <algorithm>

#include "core/error.h"
#include "core/paths.h"
#include "core/sha256.h"

namespace wm::trainkit {

Parent ReadParent(const std::string& run_dir, const std::vector<std::string>& freeze) {
  Parent p{.given = run_dir};
  std::vector<std::string> groups = freeze;  // recorded as a set: the order means nothing
  std::sort(groups.begin(), groups.end());
  groups.erase(std::unique(groups.begin(), groups.end()), groups.end());
  const std::string file = CheckpointFileIn(run_dir);
  try {
    p.archive = std::make_shared<const TensorArchiveReader>(file);
    const nlohmann::json& meta = p.archive->meta();
    p.record = {{"checkpoint_sha256", Sha256File(file)},
                {"config_hash", meta.at("config_hash").get<std::string>()},
                {"step", meta.at("step").get<int64_t>()},
                {"freeze", groups}};
  } catch (const nlohmann::json::exception& e) {
    throw ParentError(p, file + ": not a wmkit training checkpoint (meta): " + e.what());
  } catch (const Error& e) {
    throw ParentError(p, e.what());
  }
  return p;
}

nlohmann::json HashedConfig(nlohmann::json config, const nlohmann::json& init_from) {
  if (!init_from.is_null()) config["init_from"] = init_from;
  return config;
}

void CheckSameShapes(const Parent& parent, const nlohmann::json& parent_config,
                     const nlohmann::json& config, const std::vector<std::string>& keys) {
  for (const std::string& key : keys) {
    const nlohmann::json::json_pointer at("/" + key.substr(0, key.find('.')) + "/" +
                                          key.substr(key.find('.') + 1));
    const nlohmann::json theirs = parent_config.contains(at) ? parent_config.at(at) : nullptr;
    const nlohmann::json ours = config.contains(at) ? config.at(at) : nullptr;
    if (theirs != ours) {
      throw ParentError(parent,
                        key + " is " + theirs.dump() + " in the parent, " + ours.dump() + " here");
    }
  }
}

Error ParentError(const Parent& parent, const std::string& message) {
  return Error("--init-from " + parent.given + ": " + message);
}

std::vector<std::string> FrozenPrefixes(
    const std::vector<std::string>& groups,
    const std::map<std::string, std::vector<std::string>>& table, bool has_parent) {
  Check(groups.empty() || has_parent, "--freeze needs --init-from (a parent run's weights)");
  std::vector<std::string> prefixes;
  for (const std::string& group : groups) {
    auto it = table.find(group);
    if (it == table.end()) {
      std::string known;
      for (const auto& [name, unused] : table) known += (known.empty() ? "" : ", ") + name;
      throw Error("--freeze " + group + ": unknown parameter group (expected " + known + ")");
    }
    prefixes.insert(prefixes.end(), it->second.begin(), it->second.end());
  }
  return prefixes;
}

bool IsFrozen(const std::string& name, const std::vector<std::string>& frozen_prefixes) {
  for (const std::string& prefix : frozen_prefixes) {
    if (name.rfind(prefix, 0) == 0) return true;
  }
  return false;
}

}  // namespace wm::trainkit

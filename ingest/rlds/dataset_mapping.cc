#include "ingest/rlds/dataset_mapping.h"

#include <yaml-cpp/yaml.h>

#include <filesystem>

#include "core/episode.h"
#include "core/error.h"
#include "core/sectioned_yaml.h"
#include "core/shard/dataset_index.h"

namespace wm::rlds {
namespace fs = std::filesystem;

int ActionPart::Width(int feature_size) const {
  if (key.empty()) return zeros;
  return select.empty() ? feature_size : static_cast<int>(select.size());
}

nlohmann::json DatasetMapping::ToJson() const {
  nlohmann::json parts = nlohmann::json::array();
  for (const auto& p : action) {
    parts.push_back({{"key", p.key},
                     {"select", p.select},
                     {"zeros", p.zeros},
                     {"scale", p.scale},
                     {"offset", p.offset}});
  }
  auto opt = [](const std::optional<std::string>& s) {
    return s ? nlohmann::json(*s) : nlohmann::json(nullptr);
  };
  nlohmann::json j = {{"dataset", dataset},
                      {"image", image},
                      {"depth", opt(depth)},
                      {"segmentation", opt(segmentation)},
                      {"action", parts},
                      {"reward", opt(reward)},
                      {"discount", opt(discount)},
                      {"is_first", is_first},
                      {"is_last", is_last},
                      {"is_terminal", is_terminal},
                      {"language_instruction", opt(language_instruction)},
                      {"policy_id", opt(policy_id)},
                      {"episode_seed", opt(episode_seed)}};
  // Only when not the canonical space: the hashes of eef_delta mappings stay as they were.
  if (action_space != "eef_delta") j["action_space"] = action_space;
  return j;
}

DatasetMapping LoadDatasetMapping(const std::string& file) {
  DatasetMapping m;
  m.file = file;
  std::string key;
  try {
    YAML::Node y = YAML::LoadFile(file);
    CheckKnownYamlKeys(y,
                       {"dataset", "image", "depth", "segmentation", "action", "action_space",
                        "reward", "discount", "is_first", "is_last", "is_terminal",
                        "language_instruction", "policy_id", "episode_seed"},
                       file);
    auto optional = [&](const char* k) -> std::optional<std::string> {
      key = k;
      if (!y[k] || y[k].IsNull()) return std::nullopt;
      return y[k].as<std::string>();
    };
    key = "dataset", m.dataset = y[key].as<std::string>();
    key = "image", m.image = y[key].as<std::string>();
    m.depth = optional("depth");
    m.segmentation = optional("segmentation");
    m.reward = optional("reward");
    m.discount = optional("discount");
    m.language_instruction = optional("language_instruction");
    m.policy_id = optional("policy_id");
    m.episode_seed = optional("episode_seed");
    m.is_first = optional("is_first").value_or(m.is_first);
    m.is_last = optional("is_last").value_or(m.is_last);
    m.is_terminal = optional("is_terminal").value_or(m.is_terminal);
    m.action_space = optional("action_space").value_or(m.action_space);
    Check(shard::IsKnownActionSpace(m.action_space),
          "must be eef_delta, joint_position or other, got '" + m.action_space + "'");
    key = "action";
    Check(y[key] && y[key].IsSequence(), "must be a list of parts");
    int index = 0;
    for (const auto& p : y[key]) {
      const std::string where = "action[" + std::to_string(index++) + "]";
      CheckKnownYamlKeys(p,
                         p["zeros"] ? std::set<std::string>{"zeros"}
                                    : std::set<std::string>{"key", "select", "scale", "offset"},
                         file, where);
      ActionPart part;
      if (p["zeros"]) {
        part.zeros = p["zeros"].as<int>();
      } else {
        part.key = p["key"].as<std::string>();
        if (p["select"]) part.select = p["select"].as<std::vector<int>>();
        if (p["scale"]) part.scale = p["scale"].as<double>();
        if (p["offset"]) part.offset = p["offset"].as<double>();
      }
      m.action.push_back(part);
    }
  } catch (const YAML::Exception& e) {
    throw Error(std::string("invalid dataset mapping: ") + e.what(), {.file = file, .key = key});
  } catch (const Error& e) {
    throw e.WithKey(key).WithFile(file);
  }
  return m;
}

std::string FindMappingFile(const std::string& configs_dir, const std::string& dataset) {
  fs::path dir = fs::path(configs_dir) / "datasets";
  fs::path file = dir / (dataset + ".yaml");
  if (fs::exists(file)) return file.string();
  std::string known;
  if (fs::is_directory(dir)) {
    for (const auto& e : fs::directory_iterator(dir)) known += " " + e.path().stem().string();
  }
  throw Error("no dataset mapping for '" + dataset + "' (write " + file.string() +
                  ", see docs/dataset-mapping.md, or pass --mapping FILE); known:" + known,
              {.file = dir.string()});
}

}  // namespace wm::rlds

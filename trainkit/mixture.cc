#include "trainkit/mixture.h"

#include <yaml-cpp/yaml.h>

#include <cmath>

#include "core/error.h"
#include "core/sectioned_yaml.h"

namespace wm::trainkit {

std::map<std::string, double> LoadMixture(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw Error(std::string("cannot parse mixture YAML: ") + e.what(), {.file = path});
  }
  CheckKnownYamlKeys(root, {"datasets"}, path);
  Check(root["datasets"] && root["datasets"].IsSequence(), "expected a 'datasets' list",
        {.file = path, .key = "datasets"});
  std::map<std::string, double> weights;
  int i = 0;
  for (const YAML::Node& entry : root["datasets"]) {
    const std::string key = "datasets[" + std::to_string(i++) + "]";
    CheckKnownYamlKeys(entry, {"name", "weight"}, path, key);
    try {
      const std::string name = entry["name"].as<std::string>();
      Check(!name.empty(), "must not be empty", {.file = path, .key = key + ".name"});
      const double weight = entry["weight"].as<double>();
      Check(std::isfinite(weight) && weight > 0, "weight must be a positive number",
            {.file = path, .key = key + ".weight"});
      Check(weights.emplace(name, weight).second, "dataset '" + name + "' listed twice",
            {.file = path, .key = key + ".name"});
    } catch (const YAML::Exception&) {
      throw Error("each entry needs a string 'name' and a number 'weight'",
                  {.file = path, .key = key});
    }
  }
  Check(!weights.empty(), "the mixture lists no datasets", {.file = path, .key = "datasets"});
  return weights;
}

std::vector<double> MixtureWeights(const std::map<std::string, double>& mixture,
                                   const std::string& mixture_file,
                                   const std::vector<std::string>& dataset_names,
                                   const std::vector<double>& fallback) {
  if (mixture.empty()) return fallback;
  std::vector<double> out;
  for (const std::string& name : dataset_names) {
    auto it = mixture.find(name);
    Check(it != mixture.end(), "dataset '" + name + "' (given with --data) has no weight",
          {.file = mixture_file, .key = "datasets"});
    out.push_back(it->second);
  }
  return out;
}

}  // namespace wm::trainkit

#pragma once
// The two-level YAML configs (`section: {key: scalar}`) of the tokenizer and the dynamics model,
// read strictly: a value must be a scalar of the field's type (numbers finite), and an unknown
// section or key is an error, so a typo never silently falls back to a default. Header-only;
// users link yaml-cpp.
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <type_traits>

#include "core/error.h"

namespace wm {

template <class T>
const char* YamlTypeWord() {
  if constexpr (std::is_same_v<T, bool>) return "a boolean";
  if constexpr (std::is_integral_v<T>) return "an integer";
  if constexpr (std::is_floating_point_v<T>) return "a number";
  return "a string";
}

// A mapping key as a plain name. YAML allows a list or mapping as a key ("? [a]: b"); wmkit's
// files never use one, so it is an error naming `where` (the enclosing key).
inline std::string YamlKeyName(const YAML::Node& key, const std::string& file,
                               const std::string& where) {
  Check(key.IsScalar(), "expected a plain name as key, found a list or mapping",
        {.file = file, .key = where});
  return key.Scalar();
}

// Refuses a key of the mapping `node` that is not in `known`, naming it as `where`.key (or key
// at the top level): a typo must not silently fall back to a default. The message ends in
// "(hint)", by default the known keys. Non-mappings pass; the caller's type checks name them.
inline void CheckKnownYamlKeys(const YAML::Node& node, const std::set<std::string>& known,
                               const std::string& file, const std::string& where = "",
                               const std::string& hint = "") {
  if (!node.IsMap()) return;
  std::string list;
  for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
  const std::string why = "unknown key (" + (hint.empty() ? "expected " + list : hint) + ")";
  for (const auto& kv : node) {
    const std::string name = YamlKeyName(kv.first, file, where);
    Check(known.count(name) > 0, why,
          {.file = file, .key = where.empty() ? name : where + "." + name});
  }
}

// Reads `yaml_text` into `config`'s fields, which visit_fields(config, f) lists as
// f(section, key, field). Errors (wm::Error) name `file` and "section.key"; the unknown-key
// message points at `doc`. An empty document leaves every default.
template <class Config, class VisitFields>
void ReadSectionedYaml(const std::string& yaml_text, const std::string& file, const char* doc,
                       Config& config, VisitFields visit_fields) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw Error("invalid YAML: " + std::string(e.what()), {.file = file});
  }
  if (root.IsNull()) return;
  Check(root.IsMap(), "expected a mapping at the top level", {.file = file});
  std::map<std::string, std::set<std::string>> known;
  visit_fields(config, [&](const char* section, const char* key, auto& field) {
    known[section].insert(key);
    const std::string where = std::string(section) + "." + key;
    YAML::Node s = root[section];
    if (!s) return;
    Check(s.IsMap(), "expected a mapping", {.file = file, .key = section});
    YAML::Node v = s[key];
    if (!v) return;
    using T = std::decay_t<decltype(field)>;
    try {
      Check(v.IsScalar(), "expected a scalar", {.file = file, .key = where});
      field = v.as<T>();
      if constexpr (std::is_floating_point_v<T>) {  // .inf / .nan would reach checkpoints as null
        Check(std::isfinite(field), "must be a finite number", {.file = file, .key = where});
      }
    } catch (const YAML::Exception&) {
      throw Error("cannot read '" + v.Scalar() + "' as " + YamlTypeWord<T>(),
                  {.file = file, .key = where});
    }
  });
  std::string sections;
  for (const auto& [name, keys] : known) sections += (sections.empty() ? "" : ", ") + name;
  for (const auto& top : root) {
    const std::string section = YamlKeyName(top.first, file, "");
    Check(known.count(section) > 0, "unknown section (expected " + sections + ")",
          {.file = file, .key = section});
    // A repeated section name reaches here without the mapping check above.
    Check(top.second.IsMap(), "expected a mapping", {.file = file, .key = section});
    CheckKnownYamlKeys(top.second, known[section], file, section, std::string("see ") + doc);
  }
}

// The config as {section: {key: value}} JSON (manifests, checkpoints, wm::ConfigHash), and back;
// a key missing from `j` keeps its default, so configs saved before the key existed still load.
template <class Config, class VisitFields>
nlohmann::json SectionedToJson(const Config& config, VisitFields visit_fields) {
  nlohmann::json j;
  visit_fields(config, [&](const char* section, const char* key, const auto& field) {
    j[section][key] = field;
  });
  return j;
}

template <class Config, class VisitFields>
Config SectionedFromJson(const nlohmann::json& j, VisitFields visit_fields) {
  Config config;
  visit_fields(config, [&](const char* section, const char* key, auto& field) {
    if (j.contains(section) && j[section].contains(key)) j[section][key].get_to(field);
  });
  return config;
}

}  // namespace wm

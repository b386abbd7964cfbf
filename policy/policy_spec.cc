#include "policy/policy_spec.h"

#include <yaml-cpp/yaml.h>

#include <regex>
#include <set>

#include "core/error.h"

namespace wm::policy {

void CheckPolicyNames(const std::vector<PolicySpec>& policies) {
  static const std::regex valid("[a-z][a-z0-9_]{0,63}");
  std::set<std::string> seen;
  for (const PolicySpec& p : policies) {
    Check(std::regex_match(p.name, valid),
          "policy name '" + p.name + "' must match [a-z][a-z0-9_]* (at most 64 characters)",
          {.key = "--policy"});
    Check(!p.command.empty(), "policy '" + p.name + "' has an empty command", {.key = "--policy"});
    Check(seen.insert(p.name).second, "policy name '" + p.name + "' appears twice",
          {.key = "--policy"});
  }
}

PolicySpec ParsePolicySpec(const std::string& text) {
  const size_t eq = text.find('=');
  Check(eq != std::string::npos, "expected NAME=COMMAND, got '" + text + "'", {.key = "--policy"});
  PolicySpec spec{text.substr(0, eq), text.substr(eq + 1), false, ""};
  CheckPolicyNames({spec});
  return spec;
}

std::vector<PolicySpec> LoadPolicyList(const std::string& path) {
  std::vector<PolicySpec> out;
  try {
    const YAML::Node root = YAML::LoadFile(path);
    const YAML::Node list = root["policies"];
    Check(list && list.IsSequence() && list.size() > 0, "needs a non-empty 'policies' list",
          {.file = path, .key = "policies"});
    for (size_t i = 0; i < list.size(); ++i) {
      const YAML::Node& n = list[i];
      const ErrorContext at{
          .file = path, .record = static_cast<int64_t>(i), .record_label = "policy"};
      Check(n.IsMap(), "each policy is a map with name and command", at);
      for (const auto& field : n) {
        const std::string key = field.first.as<std::string>();
        Check(key == "name" || key == "command" || key == "in_distribution" || key == "description",
              "unknown field '" + key + "' (name, command, in_distribution, description)", at);
      }
      Check(n["name"] && n["command"], "a policy needs 'name' and 'command'", at);
      out.push_back({n["name"].as<std::string>(), n["command"].as<std::string>(),
                     n["in_distribution"] ? n["in_distribution"].as<bool>() : false,
                     n["description"] ? n["description"].as<std::string>() : ""});
    }
  } catch (const YAML::Exception& e) {
    throw Error(std::string("cannot read the policy list: ") + e.what(), {.file = path});
  }
  try {
    CheckPolicyNames(out);
  } catch (const Error& e) {
    throw e.WithFile(path);
  }
  return out;
}

std::vector<PolicySpec> CollectPolicies(const std::string& list,
                                        const std::vector<std::string>& specs,
                                        const std::vector<std::string>& in_distribution) {
  std::vector<PolicySpec> out;
  if (!list.empty()) out = LoadPolicyList(list);
  for (const std::string& s : specs) {
    const bool is_list =
        s.find('=') == std::string::npos && (s.ends_with(".yaml") || s.ends_with(".yml"));
    if (!is_list) {
      out.push_back(ParsePolicySpec(s));
      continue;
    }
    for (PolicySpec& p : LoadPolicyList(s)) out.push_back(std::move(p));
  }
  Check(!out.empty(), "no policy given (--policy NAME=COMMAND or a policy list)",
        {.key = "--policy"});
  for (const std::string& name : in_distribution) {
    bool found = false;
    for (PolicySpec& p : out) found |= p.name == name && (p.in_distribution = true);
    Check(found, "no policy is named '" + name + "'", {.key = "--in-distribution"});
  }
  CheckPolicyNames(out);
  return out;
}

}  // namespace wm::policy

#pragma once
// Which policies to evaluate: a name (used as the RLDS split, the report row and in errors), a
// command that starts the policy process, and whether it is in the world model's training
// distribution. From the command line (`--policy NAME=CMD`) or a policy list in YAML
// (configs/policies/*.yaml, schemas/policy-list.schema.json, docs/policy-protocol.md).
#include <string>
#include <vector>

namespace wm::policy {

struct PolicySpec {
  std::string name;     // [a-z][a-z0-9_]*, at most 64 characters
  std::string command;  // run by /bin/sh -c from the caller's working directory
  // Close to the policies that generated the world model's training data (WPE Sec. 5.1 calls
  // these in-distribution); reports keep them apart.
  bool in_distribution = false;
  std::string description;  // free text for reports
};

// "NAME=CMD" -> {NAME, CMD}. Throws wm::Error(key "--policy") on a bad name or empty command.
PolicySpec ParsePolicySpec(const std::string& text);

// A policy list file: `policies:` a sequence of {name, command, in_distribution, description}.
// Relative commands stay as written (they run from the caller's working directory). Throws
// wm::Error naming the file and the field; names must be unique.
std::vector<PolicySpec> LoadPolicyList(const std::string& path);

// The policies a command line names: those of the policy list `list` (empty: none), then one per
// entry of `specs` ("NAME=COMMAND", or the path of a .yaml / .yml policy list), with the names in
// `in_distribution` marked in-distribution. Throws wm::Error naming the option for a name in
// `in_distribution` that no policy has, for duplicate names, and when no policy is given.
std::vector<PolicySpec> CollectPolicies(const std::string& list,
                                        const std::vector<std::string>& specs,
                                        const std::vector<std::string>& in_distribution);

// Throws wm::Error(key "--policy") unless `name` is a valid, unique policy name.
void CheckPolicyNames(const std::vector<PolicySpec>& policies);

}  // namespace wm::policy

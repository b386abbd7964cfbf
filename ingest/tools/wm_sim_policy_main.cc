// wm-sim-policy: true values of policies in the tabletop world, run closed loop.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <iostream>

#include "core/cli_parse.h"
#include "core/error.h"
#include "core/log.h"
#include "core/provenance.h"
#include "ingest/tabletop/sim_policy.h"

namespace {

constexpr const char* kFooter = R"(
Each policy is a process speaking the wmkit-policy protocol v1 on stdin/stdout
(docs/policy-protocol.md; scripts/wmpolicy.py wraps a Python policy in a few lines). It runs closed
loop on episodes 0..N-1 of SPLIT as wm-gen-tabletop --seed SEED lays them out (same layouts,
looks, instructions and first frames), seeing exactly the frames the dataset stores (the decoded
JPEG at --size and --look). Writes OUT/policy_values.{json,csv} (true value = success rate with a
Wilson 95% interval), OUT/policy_episodes.csv and the episodes as an RLDS dataset
OUT/NAME/VERSION, one split per policy (docs/sim-policy.md). Same arguments -> identical bytes.

Examples:
  wm-sim-policy --out data/truth --size 64 --look plain --episodes 50 \
    --policy 'colour=scripts/tabletop_colour_policy.py --noise 0'
  wm-sim-policy --out data/truth --size 64 --look plain --policies configs/policies/tabletop.yaml

Exit codes: 0 success; 1 invalid option, a policy that failed (crashed, hung past --policy-timeout,
answered malformed, wrong-width or non-finite actions: the message names the policy, episode and
step) or a write failure; 2 usage error.)";

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"wm-sim-policy: true values of policies run closed loop in the tabletop world"};
  app.footer(kFooter);
  app.set_version_flag("--version", wm::VersionString("wm-sim-policy"));
  wm::tabletop::SimPolicyOptions o;
  std::vector<std::string> specs, in_distribution;
  std::string list, look = "varied";
  app.add_option("--out", o.out_dir, "Output directory")->required();
  app.add_option("--policy", specs, "NAME=COMMAND (repeatable); NAME is [a-z][a-z0-9_]*");
  app.add_option("--policies", list, "A policy list in YAML (configs/policies/tabletop.yaml)");
  app.add_option("--in-distribution", in_distribution,
                 "Names of --policy policies close to the training data's policies")
      ->delimiter(',');
  app.add_option("--episodes", o.episodes, "Episodes per policy")->capture_default_str();
  app.add_option("--max-steps", o.max_steps, "Horizon: steps per episode at most")
      ->capture_default_str();
  app.add_option("--size", o.size, "Image side in pixels, as the dataset's")->capture_default_str();
  app.add_option("--look", look, "varied or plain, as the dataset's")
      ->check(CLI::IsMember({"varied", "plain"}))
      ->capture_default_str();
  app.add_option("--seed", o.seed, "wm-gen-tabletop's --seed")->capture_default_str();
  app.add_option("--split", o.split, "Whose episode seeds to use")->capture_default_str();
  app.add_option("--name", o.name, "TFDS name of the episodes' dataset")->capture_default_str();
  app.add_option("--dataset-version", o.version, "Its TFDS version")->capture_default_str();
  app.add_flag("!--no-dataset", o.write_dataset, "Write the summaries only, not the episodes");
  app.add_option("--policy-timeout", o.step_timeout_s, "Seconds a policy may take per answer")
      ->capture_default_str();
  app.add_option("--policy-start-timeout", o.start_timeout_s,
                 "Seconds a policy may take to start (its hello)")
      ->capture_default_str();
  if (const int code = wm::ParseCommandLine(app, argc, argv); code >= 0) return code;
  wm::InitLogging("info");
  try {
    o.policies = wm::policy::CollectPolicies(list, specs, in_distribution);
    if (look == "plain") o.look = wm::tabletop::LookVariation::kPlain;
    const auto truths = wm::tabletop::RunSimPolicies(o);
    spdlog::info("wrote the true values of {} policies to {}/policy_values.json", truths.size(),
                 o.out_dir);
  } catch (const std::exception& e) {
    std::cerr << "wm-sim-policy: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

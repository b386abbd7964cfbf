#include "ingest/tabletop/sim_policy.h"

#include <spdlog/spdlog.h>

#include <filesystem>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/provenance.h"
#include "ingest/rlds/tfrecord.h"
#include "ingest/tabletop/closed_loop.h"
#include "ingest/tabletop/tabletop_writer.h"
#include "ingest/tabletop/tfds_features.h"
#include "policy/policy_process.h"
#include "policy/policy_seed.h"
#include "policy/policy_value.h"

namespace wm::tabletop {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kValuesJson = "policy_values.json";
constexpr const char* kValuesCsv = "policy_values.csv";
constexpr const char* kEpisodesCsv = "policy_episodes.csv";

struct EpisodeResult {
  int64_t index = 0;
  uint64_t seed = 0;
  bool success = false;
  double episode_return = 0;
  int steps = 0;
};

std::string Number(double v) {
  std::ostringstream s;
  s << std::setprecision(6) << v;
  return s.str();
}

std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  return "\"" + std::regex_replace(text, std::regex("\""), "\"\"") + "\"";
}

// Runs one policy on every episode; appends each episode's example to `writer` when given.
std::vector<EpisodeResult> RunPolicy(const SimPolicyOptions& o, const policy::PolicySpec& spec,
                                     rlds::TfRecordWriter* writer, uint64_t* bytes) {
  policy::PolicyProcess process({.name = spec.name,
                                 .command = spec.command,
                                 .action_dim = static_cast<int>(std::tuple_size_v<Action>),
                                 .image_height = o.size,
                                 .image_width = o.size,
                                 .start_timeout_s = o.start_timeout_s,
                                 .step_timeout_s = o.step_timeout_s});
  std::vector<EpisodeResult> results;
  for (int64_t i = 0; i < o.episodes; ++i) {
    const uint64_t seed = EpisodeSeed(o.seed, o.split, i);
    bool reset = false;
    const ClosedLoopEpisode episode =
        RollOutClosedLoop(seed, o.max_steps, o.look, o.size, [&](const ImageObservation& obs) {
          if (!reset) process.Reset(i, policy::PolicySeed(seed), obs.instruction), reset = true;
          const std::vector<float> a =
              process.Act({obs.rgb.data(), obs.size, obs.size, obs.instruction, i, obs.step});
          Action action;
          std::copy(a.begin(), a.end(), action.begin());
          return action;
        });
    results.push_back({i, seed, episode.rollout.success, episode.episode_return,
                       static_cast<int>(episode.rollout.steps.size())});
    if (writer) {
      const std::string example = EncodeEpisode(episode.rollout, episode.frames, o.size, spec.name);
      writer->Write(example);
      *bytes += example.size() + 16;  // TFRecord framing: 8 + 4 + 4 bytes
    }
  }
  process.Close();
  return results;
}

PolicyTruth Summarize(const policy::PolicySpec& spec, const std::vector<EpisodeResult>& results) {
  PolicyTruth t{spec};
  t.episodes = static_cast<int>(results.size());
  double returns = 0, steps = 0;
  for (const EpisodeResult& r : results) {
    t.successes += r.success;
    returns += r.episode_return;
    steps += r.steps;
  }
  const policy::SuccessRate rate = policy::WilsonInterval(t.successes, t.episodes);
  t.true_value = rate.rate, t.ci_low = rate.low, t.ci_high = rate.high;
  t.mean_return = t.episodes ? returns / t.episodes : 0;
  t.mean_steps = t.episodes ? steps / t.episodes : 0;
  return t;
}

json OptionsJson(const SimPolicyOptions& o) {
  return {{"episodes", o.episodes},
          {"max_steps", o.max_steps},
          {"size", o.size},
          {"seed", o.seed},
          {"split", o.split},
          {"look", o.look == LookVariation::kPlain ? "plain" : "varied"},
          {"dataset", o.write_dataset ? json(o.name + "/" + o.version) : json(nullptr)}};
}

void WriteSummaries(const SimPolicyOptions& o, const std::vector<PolicyTruth>& truths,
                    const std::string& episodes_csv) {
  json policies = json::array();
  std::string csv =
      "policy,in_distribution,episodes,successes,true_value,ci_low,ci_high,mean_return,"
      "mean_steps,command\n";
  for (const PolicyTruth& t : truths) {
    policies.push_back({{"policy", t.spec.name},
                        {"command", t.spec.command},
                        {"in_distribution", t.spec.in_distribution},
                        {"description", t.spec.description},
                        {"episodes", t.episodes},
                        {"successes", t.successes},
                        {"true_value", t.true_value},
                        {"ci_low", t.ci_low},
                        {"ci_high", t.ci_high},
                        {"mean_return", t.mean_return},
                        {"mean_steps", t.mean_steps}});
    csv += t.spec.name + "," + (t.spec.in_distribution ? "true" : "false") + "," +
           std::to_string(t.episodes) + "," + std::to_string(t.successes) + "," +
           Number(t.true_value) + "," + Number(t.ci_low) + "," + Number(t.ci_high) + "," +
           Number(t.mean_return) + "," + Number(t.mean_steps) + "," + CsvField(t.spec.command) +
           "\n";
  }
  const json summary = {{"format", "wmkit-policy-values"},
                        {"format_version", 1},
                        {"environment", "tabletop"},
                        {"value",
                         "success rate: fraction of episodes whose block reached the goal within "
                         "max_steps (equal to the mean return: reward 1 on that step, else 0)"},
                        {"interval", "wilson"},
                        {"level", 0.95},
                        {"options", OptionsJson(o)},
                        {"policies", policies},
                        {"provenance", MakeProvenance("wm-sim-policy", OptionsJson(o))}};
  const fs::path out(o.out_dir);
  WriteFileAtomically((out / kEpisodesCsv).string(), episodes_csv);
  WriteFileAtomically((out / kValuesCsv).string(), csv);
  WriteFileAtomically((out / kValuesJson).string(), summary.dump(2) + "\n");  // last: the marker
}

// An earlier run's finished outputs must not outlive a run that fails.
void RemoveFinishedMarkers(const SimPolicyOptions& o, const fs::path& dataset_dir) {
  std::error_code ec;
  for (const fs::path& p :
       {fs::path(o.out_dir) / kValuesJson, fs::path(o.out_dir) / kValuesCsv,
        fs::path(o.out_dir) / kEpisodesCsv, dataset_dir / "dataset_info.json"}) {
    fs::remove(p, ec);
    if (ec) throw Error("cannot remove an earlier run's output: " + ec.message(), {.file = p});
  }
}

}  // namespace

void SimPolicyOptions::Check() const {
  wm::Check(!out_dir.empty(), "an output directory is required", {.key = "--out"});
  wm::Check(!policies.empty(), "at least one policy is needed", {.key = "--policy"});
  policy::CheckPolicyNames(policies);
  wm::Check(episodes >= 1 && episodes <= 1000000, "must be in 1..1000000", {.key = "--episodes"});
  wm::Check(max_steps >= 1 && max_steps <= 1000, "must be in 1..1000", {.key = "--max-steps"});
  wm::Check(size >= 64 && size <= 256, "must be in 64..256 pixels", {.key = "--size"});
  wm::Check(std::regex_match(split, std::regex("[a-z][a-z0-9_]*")),
            "split '" + split + "' must be [a-z][a-z0-9_]*", {.key = "--split"});
  wm::Check(std::regex_match(name, std::regex("[a-z][a-z0-9_]*")),
            "dataset name '" + name + "' must be snake_case", {.key = "--name"});
  wm::Check(std::regex_match(version, std::regex("[0-9]+\\.[0-9]+\\.[0-9]+")),
            "dataset version must be MAJOR.MINOR.PATCH", {.key = "--dataset-version"});
  wm::Check(step_timeout_s > 0 && start_timeout_s > 0, "timeouts must be positive",
            {.key = "--policy-timeout"});
}

std::vector<PolicyTruth> RunSimPolicies(const SimPolicyOptions& o) {
  o.Check();
  const fs::path dataset_dir = fs::path(o.out_dir) / o.name / o.version;
  try {
    fs::create_directories(o.write_dataset ? dataset_dir : fs::path(o.out_dir));
  } catch (const fs::filesystem_error& e) {
    throw Error(std::string("cannot create the output directory: ") + e.what(),
                {.file = o.out_dir});
  }
  RemoveFinishedMarkers(o, dataset_dir);
  std::vector<PolicyTruth> truths;
  std::vector<SplitInfo> splits;
  std::set<std::string> written;
  std::string episodes_csv = "policy,episode,episode_seed,success,return,steps\n";
  for (const policy::PolicySpec& spec : o.policies) {
    spdlog::info("policy {}: {} episodes of at most {} steps ({})", spec.name, o.episodes,
                 o.max_steps, spec.command);
    const std::string file = TfdsShardFileName(o.name, spec.name, 0, 1);
    std::optional<rlds::TfRecordWriter> writer;
    if (o.write_dataset) writer.emplace((dataset_dir / file).string());
    SplitInfo split{spec.name, 0, {static_cast<uint64_t>(o.episodes)}};
    const std::vector<EpisodeResult> results =
        RunPolicy(o, spec, writer ? &*writer : nullptr, &split.num_bytes);
    if (writer) writer->Close(), written.insert(file), splits.push_back(split);
    for (const EpisodeResult& r : results) {
      episodes_csv += spec.name + "," + std::to_string(r.index) + "," + std::to_string(r.seed) +
                      "," + (r.success ? "1" : "0") + "," + Number(r.episode_return) + "," +
                      std::to_string(r.steps) + "\n";
    }
    truths.push_back(Summarize(spec, results));
    const PolicyTruth& t = truths.back();
    spdlog::info("policy {}: true value {:.3f} [{:.3f}, {:.3f}] ({} of {} episodes)", spec.name,
                 t.true_value, t.ci_low, t.ci_high, t.successes, t.episodes);
  }
  if (o.write_dataset) {
    RemoveStaleShards(dataset_dir.string(), o.name, written);
    const std::string description =
        "Closed-loop episodes of policies in the wmkit tabletop world (wm-sim-policy, seed " +
        std::to_string(o.seed) + ", split " + o.split +
        ", one split per policy). Steps as in "
        "wm-gen-tabletop's datasets.";
    WriteFileAtomically((dataset_dir / "features.json").string(), TabletopFeaturesJson(o.size));
    WriteFileAtomically((dataset_dir / "dataset_info.json").string(),
                        DatasetInfoJson(o.name, o.version, description, splits));
  }
  WriteSummaries(o, truths, episodes_csv);
  return truths;
}

}  // namespace wm::tabletop

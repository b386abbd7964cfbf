// wm-shard: inspect, verify, dump, merge and slice wmkit shard datasets.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <iostream>

#include "core/cli_parse.h"
#include "core/error.h"
#include "core/log.h"
#include "core/provenance.h"
#include "core/shard/dataset_reader.h"
#include "ingest/dataset_summary.h"
#include "ingest/episode_json.h"
#include "ingest/merge.h"
#include "ingest/slice.h"

namespace {

constexpr const char* kFooter = R"(
Examples:
  wm-shard info data/shards/train          # summary; --json for the whole index
  wm-shard verify data/shards/train
  wm-shard dump data/shards/train --episode 3
  wm-shard merge --output data/shards/all data/shards/part-0 data/shards/part-1
  wm-shard slice --from-step 8 --min-steps 9 --output data/val-from8 data/shards/val

Exit codes: 0 success (verify: every checksum matched), 1 a check failed or bad input, 2 usage.)";

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"wm-shard: inspect, verify, dump, merge and slice wmkit shard datasets"};
  app.footer(kFooter);
  app.set_version_flag("--version", wm::VersionString("wm-shard"));
  app.require_subcommand(1);
  std::string dir, output;
  std::vector<std::string> parts;
  int64_t episode = -1;
  bool as_json = false;
  auto* info = app.add_subcommand("info", "Print a dataset summary (--json: the whole index.json)");
  info->add_option("dir", dir, "Dataset directory")->required();
  info->add_flag("--json", as_json, "Print index.json as parsed and checked");
  auto* verify = app.add_subcommand("verify", "Re-check every hash and CRC");
  verify->add_option("dir", dir, "Dataset directory")->required();
  auto* dump = app.add_subcommand("dump", "Print episodes as JSON (all, or one)");
  dump->add_option("dir", dir, "Dataset directory")->required();
  dump->add_option("--episode", episode, "Global episode index (default: all episodes)");
  auto* merge = app.add_subcommand("merge", "Join part directories (in the given order)");
  merge->add_option("--output", output, "Merged dataset directory")->required();
  merge->add_option("parts", parts, "Part directories")->required();
  wm::ingest::SliceOptions slice_options;
  auto* slice = app.add_subcommand(
      "slice", "The same episodes from step --from-step on (is_first there; too short: skipped)");
  slice->add_option("dir", slice_options.input, "Dataset directory")->required();
  slice->add_option("--output", slice_options.output, "New dataset directory")->required();
  slice->add_option("--from-step", slice_options.from_step, "First step kept")
      ->check(CLI::NonNegativeNumber);
  slice->add_option("--max-steps", slice_options.max_steps, "Steps kept at most (0: to the end)")
      ->check(CLI::NonNegativeNumber);
  slice
      ->add_option("--min-steps", slice_options.min_steps,
                   "Skip episodes with fewer steps left (wm-eval --horizon H needs H + 1)")
      ->check(CLI::PositiveNumber);
  if (const int rc = wm::ParseCommandLine(app, argc, argv); rc >= 0) return rc;
  wm::InitLogging("info");
  try {
    if (*info) {
      wm::shard::DatasetIndex index = wm::shard::ReadIndex(dir);
      std::cout << (as_json ? wm::shard::IndexToJson(index).dump(2) + "\n"
                            : wm::ingest::FormatSummary(index));
    } else if (*verify) {
      wm::shard::VerifyReport r = wm::shard::VerifyDataset(dir);
      std::cout << "OK " << r.episodes << " episodes, " << r.steps << " steps, " << r.bytes
                << " bytes verified\n";
    } else if (*dump) {
      wm::shard::DatasetReader reader(dir);
      nlohmann::json out = nlohmann::json::array();
      if (episode >= 0) {  // ReadEpisode names the dataset when K is out of range
        out = wm::ingest::EpisodeToJson(reader.ReadEpisode(static_cast<size_t>(episode)));
      } else {
        for (size_t k = 0; k < reader.num_episodes(); ++k) {
          out.push_back(wm::ingest::EpisodeToJson(reader.ReadEpisode(k)));
        }
      }
      std::cout << out.dump() << "\n";
    } else if (*merge) {
      auto index = wm::ingest::MergeDatasets(parts, output);
      spdlog::info("merged {} parts: {} episodes in {} shards -> {}", parts.size(),
                   index.num_episodes, index.shards.size(), output);
    } else if (*slice) {
      // index.json's `skipped` also lists what the input had left out; the log counts apart
      const size_t inherited =
          wm::shard::DatasetReader(slice_options.input).index().skipped.size();
      auto index = wm::ingest::SliceDataset(slice_options);
      spdlog::info("sliced {} episodes ({} steps) from step {} -> {}; {} too short, {} already "
                   "skipped in the input",
                   index.num_episodes, index.num_steps, slice_options.from_step,
                   slice_options.output, index.skipped.size() - inherited, inherited);
    }
  } catch (const std::exception& e) {
    std::cerr << "wm-shard: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

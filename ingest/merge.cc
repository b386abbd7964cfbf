#include "ingest/merge.h"

#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/provenance.h"
#include "core/sha256.h"
#include "core/shard/dataset_reader.h"
#include "core/shard/dataset_writer.h"

namespace wm::ingest {
namespace fs = std::filesystem;
using nlohmann::json;

shard::DatasetIndex MergeDatasets(const std::vector<std::string>& parts,
                                  const std::string& output) {
  Check(!parts.empty(), "merge needs at least one part directory");
  Check(!fs::exists(fs::path(output) / shard::kIndexFileName),
        "output already holds a dataset; merge writes a new directory", {.file = output});
  fs::create_directories(output);
  shard::DatasetIndex merged;
  json part_hashes = json::array(), inputs = json::array();
  std::vector<float> actions;
  for (const auto& dir : parts) {
    shard::DatasetReader reader(dir);
    const shard::DatasetIndex& x = reader.index();
    if (merged.shards.empty() && merged.dataset.empty()) {
      merged.dataset = x.dataset, merged.split = x.split, merged.features = x.features;
      merged.source = {{"format", x.source.value("format", "")}};
    }
    Check(x.dataset == merged.dataset && x.split == merged.split && x.features == merged.features,
          "part differs from the first part in dataset, split or streams", {.file = dir});
    for (size_t s = 0; s < x.shards.size(); ++s) {
      shard::ShardInfo info = x.shards[s];
      std::string to =
          (fs::path(output) / shard::ShardFileName(int(merged.shards.size()))).string();
      // Copy via the atomic writer: a killed merge never leaves a partial shard under its name.
      WriteFileAtomically(to, ReadFile((fs::path(dir) / info.file).string()));
      Check(Sha256File(to) == info.sha256, "copied shard does not match its hash", {.file = to});
      info.file = fs::path(to).filename().string();
      merged.shards.push_back(info);
      reader.shard(s).AppendActions(actions);
    }
    for (const auto& in : x.source.value("inputs", json::array())) inputs.push_back(in);
    merged.skipped.insert(merged.skipped.end(), x.skipped.begin(), x.skipped.end());
    merged.num_episodes += x.num_episodes;
    merged.num_steps += x.num_steps;
    part_hashes.push_back(x.provenance.value("config_hash", ""));
  }
  merged.source["inputs"] = inputs;
  merged.action_stats = shard::ComputeActionStats(actions, shard::ActionDimOf(merged.features));
  merged.provenance = MakeProvenance("wm-shard merge", {{"parts", part_hashes}});
  shard::WriteIndex(output, merged);
  return merged;
}

}  // namespace wm::ingest

#include "ingest/dataset_summary.h"

#include <fmt/format.h>

namespace wm::ingest {

std::string FormatSummary(const shard::DatasetIndex& x) {
  uint64_t bytes = 0;
  for (const auto& s : x.shards) bytes += s.bytes;
  std::string out = fmt::format(
      "dataset   {} (split {}, source format {})\n"
      "episodes  {}  steps {}  shards {}  size {:.1f} MB\n",
      x.dataset, x.split, x.source.value("format", "?"), x.num_episodes, x.num_steps,
      x.shards.size(), static_cast<double>(bytes) / 1e6);
  for (const auto& [name, f] : x.features.items()) {
    if (name == "action") continue;
    out += fmt::format("stream    {:<13} {} {} {}\n", name, f.value("encoding", ""),
                       f.value("dtype", ""), f.value("shape", nlohmann::json()).dump());
  }
  const nlohmann::json action = x.features.value("action", nlohmann::json::object());
  out += fmt::format("{:<9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9}   ({}-dim {})\n", "action", "mean",
                     "std", "min", "q01", "q99", "max", shard::ActionDimOf(x.features),
                     action.value("space", "eef_delta"));
  const auto& s = x.action_stats;
  const auto names = action.value("names", std::vector<std::string>());
  for (size_t d = 0; d < s.mean.size(); ++d) {
    out += fmt::format("  {:<7} {:>9.4f} {:>9.4f} {:>9.4f} {:>9.4f} {:>9.4f} {:>9.4f}\n",
                       d < names.size() ? names[d] : std::to_string(d), s.mean[d], s.std[d],
                       s.min[d], s.q01[d], s.q99[d], s.max[d]);
  }
  out += fmt::format("skipped   {}\n", x.skipped.size());
  for (const auto& k : x.skipped) out += fmt::format("  {} #{}: {}\n", k.file, k.record, k.reason);
  out += fmt::format("made by   {} (commit {}), config {}\n", x.provenance.value("tool", "?"),
                     x.provenance.value("git_commit", "?"),
                     x.provenance.value("config_hash", "?").substr(0, 16));
  return out;
}

}  // namespace wm::ingest

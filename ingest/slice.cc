#include "ingest/slice.h"

#include <algorithm>
#include <filesystem>
#include <utility>

#include "core/episode.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/provenance.h"
#include "core/shard/dataset_reader.h"
#include "core/shard/dataset_writer.h"

namespace wm::ingest {
namespace {

// Keeps rows [from, from + count) of `width` values each, in place (no copy of the kept frames).
template <class T>
void Keep(std::vector<T>& v, int64_t from, int64_t count, int64_t width = 1) {
  v.erase(v.begin() + (from + count) * width, v.end());
  v.erase(v.begin(), v.begin() + from * width);
}

nlohmann::json SliceConfig(const SliceOptions& o, const shard::DatasetIndex& input) {
  return {{"from_step", o.from_step},
          {"max_steps", o.max_steps},
          {"min_steps", o.min_steps},
          {"input_config_hash", input.provenance.value("config_hash", "")}};
}

}  // namespace

Episode SliceEpisode(Episode e, int64_t from, int64_t count) {
  Check(from >= 0 && count >= 1 && from + count <= e.num_steps,
        "slice [" + std::to_string(from) + ", " + std::to_string(from + count) +
            ") is outside the episode's " + std::to_string(e.num_steps) + " steps",
        {.file = e.source_file, .record = e.source_record});
  e.episode_key += "@" + std::to_string(from);
  e.num_steps = count;
  Keep(e.actions, from, count, e.action_dim);
  Keep(e.rewards, from, count);
  Keep(e.discounts, from, count);
  Keep(e.is_first, from, count);
  Keep(e.is_last, from, count);
  Keep(e.is_terminal, from, count);
  e.is_first.front() = 1;  // the slice is an episode of its own
  for (auto& [name, stream] : e.images) Keep(stream.frames, from, count);
  return e;
}

shard::DatasetIndex SliceDataset(const SliceOptions& o) {
  Check(o.from_step >= 0, "--from-step must be >= 0", {.key = "--from-step"});
  Check(o.max_steps >= 0, "--max-steps must be >= 0 (0: to the episode's end)",
        {.key = "--max-steps"});
  Check(o.min_steps >= 1, "--min-steps must be >= 1", {.key = "--min-steps"});
  Check(o.max_steps == 0 || o.min_steps <= o.max_steps,
        "--min-steps must be at most --max-steps: every episode would be skipped",
        {.key = "--min-steps"});
  Check(!std::filesystem::exists(std::filesystem::path(o.output) / shard::kIndexFileName),
        "output already holds a dataset; slice writes a new directory", {.file = o.output});
  shard::DatasetReader reader(o.input);
  const shard::DatasetIndex& in = reader.index();
  const nlohmann::json config = SliceConfig(o, in);
  shard::DatasetWriter writer({.dir = o.output, .config_hash = ConfigHash(config)});
  Progress progress("slice", reader.num_episodes(), "episodes");
  progress.Add(writer.resume_position());
  for (uint64_t k = writer.resume_position(); k < reader.num_episodes(); ++k, progress.Add()) {
    Episode e = reader.ReadEpisode(k);
    const int64_t left = e.num_steps - o.from_step;
    const int64_t count = o.max_steps > 0 ? std::min(left, o.max_steps) : left;
    if (count < o.min_steps) {
      writer.Skip({.file = e.source_file,
                   .record = e.source_record,
                   .reason = std::to_string(std::max<int64_t>(count, 0)) + " steps from step " +
                             std::to_string(o.from_step) + " (--min-steps " +
                             std::to_string(o.min_steps) + ")"},
                  k);
      continue;
    }
    writer.Add(SliceEpisode(std::move(e), o.from_step, count), k);
  }
  progress.Finish();
  shard::DatasetIndex out;
  out.dataset = in.dataset, out.split = in.split, out.source = in.source;
  out.skipped = in.skipped;  // what the input had already left out, then the slice's own
  out.provenance = MakeProvenance("wm-shard slice", config);
  return writer.Finish(out);
}

}  // namespace wm::ingest

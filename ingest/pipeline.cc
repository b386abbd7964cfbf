// wm-ingest's work: list input episodes, take this job's block, then load + check + transform
// them on worker threads and write them in input order, so output bytes never depend on
// thread timing.
#include <spdlog/spdlog.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <opencv2/core/version.hpp>
#include <variant>

#include "core/error.h"
#include "core/progress.h"
#include "core/provenance.h"
#include "core/sha256.h"
#include "core/shard/dataset_index.h"
#include "core/shard/dataset_writer.h"
#include "ingest/image_codec.h"
#include "ingest/ingest_options.h"
#include "ingest/open_source.h"
#include "ingest/ordered_loader.h"
#include "ingest/validate.h"

namespace wm::ingest {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

using LoadResult = std::variant<Episode, Error>;

LoadResult LoadOne(const EpisodeSource& source, const EpisodeRef& ref, const IngestOptions& o) {
  try {
    Episode e = source.Load(ref);
    ValidateEpisode(e, o.full_image_check);
    if (o.resize_width > 0) {
      for (auto& [name, frames] : e.images) {
        ResizeFrames(frames, o.resize_width, o.resize_height, /*nearest=*/name != "image");
      }
    }
    return e;
  } catch (const Error& err) {
    return err.WithRecord(ref.record).WithFile(ref.path);  // keeps context Load already set
  } catch (const std::exception& err) {
    return Error(err.what(), {.file = ref.path, .record = ref.record});
  }
}

// Fault injection for the kill/resume tests: WMKIT_FAULT_KILL_AFTER=N SIGKILLs this process
// right after the N-th input episode was handed to the writer, as a crash would.
void MaybeInjectKill(uint64_t episodes_done) {
  static const char* env = std::getenv("WMKIT_FAULT_KILL_AFTER");
  if (env != nullptr && std::strtoull(env, nullptr, 10) == episodes_done) std::raise(SIGKILL);
}

// Every input file read (a folder episode contributes each file in its directory).
json HashInputs(const std::vector<EpisodeRef>& refs) {
  std::map<std::string, std::string> files;  // rel -> path, sorted and unique
  for (const auto& r : refs) {
    if (!fs::is_directory(r.path)) {
      files.emplace(r.rel_path, r.path);
      continue;
    }
    for (const auto& e : fs::recursive_directory_iterator(r.path)) {
      if (e.is_regular_file()) {
        files.emplace((fs::path(r.rel_path) / fs::relative(e.path(), r.path)).string(),
                      e.path().string());
      }
    }
  }
  json inputs = json::array();
  for (const auto& [rel, path] : files) {
    inputs.push_back({{"path", rel}, {"bytes", fs::file_size(path)}, {"sha256", Sha256File(path)}});
  }
  return inputs;
}

}  // namespace

void IngestOptions::Check() const {
  wm::Check(!input.empty() && !output.empty(), "--input and --output are required");
  wm::Check(fs::exists(input), "input does not exist", {.file = input});
  wm::Check(on_error == "fail" || on_error == "skip", "--on-error must be fail or skip");
  wm::Check(num_shards >= 1 && shard_index >= 0 && shard_index < num_shards,
            "--shard-index must be in [0, --num-shards)");
  wm::Check(shard_size_mb > 0, "--shard-size-mb must be positive");
  wm::Check(threads >= 1 && threads <= 256, "--threads must be in [1, 256]");
  wm::Check((resize_width == 0) == (resize_height == 0) && resize_width >= 0 && resize_height >= 0,
            "--resize must be WxH with both positive");
  wm::Check(action_space.empty() || format == "hdf5" || format == "folder",
            "--action-space applies to hdf5 and folder inputs (a LeRobot mapping names its "
            "action_space; RLDS actions are the canonical 7)");
  wm::Check(
      action_space.empty() || shard::IsKnownActionSpace(action_space),
      "--action-space must be eef_delta, joint_position or other, got '" + action_space + "'");
}

json IngestOptions::ToConfig() const {
  return {{"format", format},
          {"dataset", dataset},
          {"split", split},
          {"camera", camera},
          {"hdf5_depth", hdf5_depth},
          {"resize", {resize_width, resize_height}},
          {"shard_size_mb", shard_size_mb},
          {"shard_index", shard_index},
          {"num_shards", num_shards},
          {"max_episodes", max_episodes},
          {"on_error", on_error},
          {"full_image_check", full_image_check},
          {"zstd_level", zstd_level},
          {"shard_format_version", 1}};
}

IngestSummary RunIngest(const IngestOptions& o) {
  o.Check();
  auto start = std::chrono::steady_clock::now();
  std::unique_ptr<EpisodeSource> source = OpenSource(o);
  json config = o.ToConfig();
  config["source"] = source->Describe();
  const std::string config_hash = ConfigHash(config);

  IngestSummary summary;
  if (fs::exists(fs::path(o.output) / "index.json")) {
    shard::DatasetIndex existing = shard::ReadIndex(o.output);
    wm::Check(existing.provenance.value("config_hash", "") == config_hash,
              "output already holds a dataset made with other options; choose another --output "
              "or delete it",
              {.file = o.output});
    spdlog::info("{} is already complete for this config; nothing to do", o.output);
    summary.already_complete = true;
    summary.episodes = existing.num_episodes;
    return summary;
  }

  std::vector<shard::SkippedEpisode> damaged;
  std::vector<EpisodeRef> refs = source->ListEpisodes(o.on_error == "skip" ? &damaged : nullptr);
  if (o.max_episodes >= 0 && refs.size() > static_cast<size_t>(o.max_episodes)) {
    refs.resize(static_cast<size_t>(o.max_episodes));
  }
  // Contiguous blocks, so merging the parts in order keeps the single-job episode order.
  const size_t n = refs.size(), i = static_cast<size_t>(o.shard_index),
               k = static_cast<size_t>(o.num_shards);
  refs = std::vector<EpisodeRef>(refs.begin() + static_cast<std::ptrdiff_t>(n * i / k),
                                 refs.begin() + static_cast<std::ptrdiff_t>(n * (i + 1) / k));
  spdlog::info("ingest {} -> {}: {} episodes (job {}/{})", o.input, o.output, refs.size(),
               o.shard_index, o.num_shards);

  shard::DatasetWriter writer(
      {.dir = o.output,
       .shard_size_bytes = static_cast<uint64_t>(o.shard_size_mb * 1048576.0),
       .zstd_level = o.zstd_level,
       .config_hash = config_hash});
  summary.resumed_from = writer.resume_position();
  if (summary.resumed_from > 0) {
    spdlog::info("resuming after {} episodes in {} finished shards", summary.resumed_from,
                 writer.resumed_shards());
  }
  Progress progress("ingest", refs.size(), "episodes");
  progress.Add(summary.resumed_from);
  // Workers load and check while this thread writes, in input order; at most a few episodes
  // per thread are in memory at once.
  OrderedLoader<LoadResult> loader(summary.resumed_from, refs.size(), o.threads,
                                   static_cast<size_t>(o.threads) * 4,
                                   [&](size_t i) { return LoadOne(*source, refs[i], o); });
  for (size_t i = summary.resumed_from; i < refs.size(); ++i) {
    LoadResult result = loader.Take(i);
    const EpisodeRef& ref = refs[i];
    if (auto* err = std::get_if<Error>(&result)) {
      if (o.on_error == "fail") throw *err;
      spdlog::warn("skipping bad episode: {}", err->what());
      writer.Skip({ref.rel_path, ref.record, err->message()}, i);
    } else {
      writer.Add(std::get<Episode>(result), i);
      MaybeInjectKill(i + 1);
    }
    progress.Add();
  }
  progress.Finish();

  shard::DatasetIndex index;
  index.dataset = o.dataset.empty() ? source->dataset_name() : o.dataset;
  index.split = o.split;
  index.source = {{"format", source->format()}, {"inputs", HashInputs(refs)}};
  index.skipped = damaged;
  if (o.shard_index == 0) {  // once over all jobs of a sharded ingest
    for (auto& absent : source->Absent()) index.skipped.push_back(std::move(absent));
  }
  index.provenance = MakeProvenance("wm-ingest", config, {{"opencv", CV_VERSION}});
  index = writer.Finish(index);
  summary.episodes = index.num_episodes;
  summary.steps = index.num_steps;
  summary.skipped = index.skipped.size();
  for (const auto& s : index.shards) summary.bytes += s.bytes;
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace wm::ingest

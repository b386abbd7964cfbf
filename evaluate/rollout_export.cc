#include "evaluate/rollout_export.h"

#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include "core/atomic_file.h"
#include "core/episode.h"
#include "core/error.h"
#include "core/image_codec.h"
#include "core/provenance.h"
#include "core/sha256.h"
#include "evaluate/manifest.h"
#include "tokenize/tokenizer.h"

namespace wm::evaluate {
namespace fs = std::filesystem;
namespace {

// Makes a rename durable (atomic_file.cc does the same for files).
void SyncDirectory(const fs::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (fd < 0) return;  // some filesystems refuse; the rename is still atomic
  ::fsync(fd);
  ::close(fd);
}

std::string FrameName(int64_t step) {
  char name[32];
  std::snprintf(name, sizeof(name), "frame_%04lld.png", static_cast<long long>(step));
  return name;
}

// actions.csv rows of steps [first, first + count): the logged action taken at each frame.
// The canonical action has its names (docs/folder-format.md); another width a0, a1, ...
// (meta.json's action_space keeps the space when the folder is read back).
std::string ActionsCsv(const Episode& ep, int64_t first, int64_t count) {
  const int64_t dim = ep.action_dim;
  std::string csv;
  for (int64_t d = 0; d < dim; ++d) {
    csv += (d ? "," : "") + (dim == kActionDim && ep.action_space == "eef_delta"
                                 ? std::string(kActionNames[d])
                                 : "a" + std::to_string(d));
  }
  csv += "\n";
  for (int64_t t = first; t < first + count; ++t) {
    for (int64_t d = 0; d < dim; ++d) {
      char cell[32];
      std::snprintf(cell, sizeof(cell), "%.9g", ep.actions.at(t * dim + d));
      csv += (d ? "," : "") + std::string(cell);
    }
    csv += "\n";
  }
  return csv;
}

// One episode folder: frames `clip` 0.. as steps first.., its actions and meta, committed whole.
void WriteEpisodeFolder(const fs::path& dataset, int64_t episode, const Clip& clip, int64_t first,
                        const Episode& ep, const nlohmann::json& meta) {
  const std::string name = "episode_" + std::to_string(episode);
  const fs::path final_dir = dataset / name, temp = dataset / ("." + name + ".tmp");
  fs::remove_all(temp);  // a killed run's leftovers
  fs::create_directories(temp);
  for (int64_t t = 0; t < clip.frames; ++t) {
    const std::vector<uint8_t> rgb = tokenize::PlanarToRgb8(clip.frame(t), clip.size);
    WriteFileAtomically((temp / FrameName(first + t)).string(),
                        EncodePng(rgb.data(), clip.size, clip.size, 3));
  }
  WriteFileAtomically((temp / "actions.csv").string(), ActionsCsv(ep, first, clip.frames));
  WriteFileAtomically((temp / "meta.json").string(), meta.dump(2) + "\n");
  fs::remove_all(final_dir);  // an earlier run's episode: replaced, never mixed
  fs::rename(temp, final_dir);
  SyncDirectory(dataset);
}

}  // namespace

RolloutExporter::RolloutExporter(const EvalOptions& o, const std::string& name,
                                 const std::string& checkpoint_file,
                                 const std::string& tokenizer_sha256) {
  if (o.save_rollouts.empty()) return;
  dir_ = (fs::path(o.save_rollouts) / name).string();
  const nlohmann::json config = EvalConfigJson(o);
  source_ = {{"checkpoint", {{"name", name}, {"sha256", Sha256File(checkpoint_file)}}},
             {"tokenizer_sha256", tokenizer_sha256},
             {"eval_config", config},
             {"eval_config_hash", ConfigHash(config)},
             {"git_commit", kGitCommit}};
}

void RolloutExporter::Write(int64_t episode, int64_t source_episode, const Episode& ep,
                            const Clip& real, const std::map<std::string, Clip>& clips) const {
  if (dir_.empty()) return;
  std::map<std::string, const Clip*> kinds;
  for (const auto& [kind, clip] : clips) kinds[kind] = &clip;
  const Clip target = SubClip(real, 1, real.frames - 1), given = SubClip(real, 0, 1);
  kinds["real"] = &target;
  kinds["context"] = &given;
  for (const auto& [kind, clip] : kinds) {
    const int64_t first = kind == "context" ? 0 : 1;
    nlohmann::json meta = {{"language_instruction", ep.language_instruction},
                           {"policy_id", ep.policy_id},
                           {"terminal", false},  // cut at the horizon, not ended
                           {"action_space", ep.action_space}};
    if (ep.episode_seed) meta["episode_seed"] = *ep.episode_seed;
    meta["wmkit_export"] = source_;
    meta["wmkit_export"].update({{"kind", kind},
                                 {"episode", episode},
                                 {"source_episode", source_episode},
                                 {"source_episode_key", ep.episode_key},
                                 {"first_step", first},
                                 {"steps", clip->frames},
                                 {"sample", 0}});
    WriteEpisodeFolder(fs::path(dir_) / kind, episode, *clip, first, ep, meta);
  }
}

}  // namespace wm::evaluate

#include "ingest/tabletop/tabletop_writer.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <regex>
#include <set>
#include <thread>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/provenance.h"
#include "ingest/rlds/tfrecord.h"
#include "ingest/tabletop/episode.h"
#include "ingest/tabletop/tfds_features.h"

namespace wm::tabletop {
namespace {

namespace fs = std::filesystem;

struct SplitPlan {
  std::string name;
  int episodes = 0;
};

// Contiguous, balanced shards; earlier shards take the remainder (TFDS: 5 over 2 -> 3, 2).
std::vector<uint64_t> ShardLengths(int episodes, int files) {
  const int shards = std::min(episodes, files);
  std::vector<uint64_t> lengths(shards, episodes / shards);
  for (int i = 0; i < episodes % shards; ++i) ++lengths[i];
  return lengths;
}

// Empty for the default region, so datasets without --goal-region keep their bytes.
std::string DescribeGoalRegion(const TabletopOptions& o) {
  const GoalRegion& g = o.goal_region;
  if (g == GoalRegion{}) return "";
  return fmt::format(", goal region x [{}, {}] y [{}, {}] m", g.x_min, g.x_max, g.y_min, g.y_max);
}

std::string Describe(const TabletopOptions& o) {
  std::string policies;
  for (const std::string& p : o.policies) policies += (policies.empty() ? "" : ",") + p;
  return "Synthetic tabletop pick-and-place episodes written by wm-gen-tabletop (wmkit " +
         std::string(kWmkitVersion) + ", seed " + std::to_string(o.seed) + ", max_steps " +
         std::to_string(o.max_steps) + ", policies " + policies +
         (o.look == LookVariation::kPlain ? ", plain look" : "") + DescribeGoalRegion(o) +
         "). Per step: " + std::to_string(o.size) + "x" + std::to_string(o.size) +
         " RGB JPEG, depth PNG (uint16 millimetres along the optical axis), segmentation PNG "
         "(0 table, 1 arm and gripper, 2 block, 3 goal region), action [dx, dy, dz, droll, "
         "dpitch, dyaw, gripper (1 = closed)].";
}

// Simulates episodes [first, first + count) of a split (cheap: no rendering).
std::vector<Rollout> RollOutAll(const TabletopOptions& o, const std::string& split, int64_t first,
                                int count) {
  std::vector<Rollout> rollouts;
  rollouts.reserve(count);
  for (int i = 0; i < count; ++i) {
    rollouts.push_back(RollOut(EpisodeSeed(o.seed, split, first + i), o.PolicyForEpisode(first + i),
                               o.max_steps, o.look, o.goal_region));
  }
  return rollouts;
}

// Renders and encodes on all cores; the result is in index order whatever the thread count.
std::vector<std::string> EncodeAll(const std::vector<Rollout>& rollouts, int size) {
  std::vector<std::string> encoded(rollouts.size());
  const size_t threads = std::clamp<size_t>(std::thread::hardware_concurrency(), 1,
                                            std::max<size_t>(rollouts.size(), 1));
  std::vector<std::thread> workers;
  std::vector<std::exception_ptr> errors(threads);
  for (size_t w = 0; w < threads; ++w) {
    workers.emplace_back([&, w] {
      try {
        for (size_t i = w; i < rollouts.size(); i += threads) {
          encoded[i] = EncodeEpisode(rollouts[i], size);
        }
      } catch (...) {
        errors[w] = std::current_exception();
      }
    });
  }
  for (std::thread& t : workers) t.join();
  for (const std::exception_ptr& e : errors) {
    if (e) std::rethrow_exception(e);
  }
  return encoded;
}

}  // namespace

void TabletopOptions::Check() const {
  wm::Check(!out_dir.empty(), "an output directory is required", {.key = "--out"});
  wm::Check(std::regex_match(name, std::regex("[a-z][a-z0-9_]*")),
            "dataset name '" + name + "' must be snake_case ([a-z][a-z0-9_]*), as TFDS requires",
            {.key = "--name"});
  wm::Check(std::regex_match(version, std::regex("[0-9]+\\.[0-9]+\\.[0-9]+")),
            "dataset version '" + version + "' must be MAJOR.MINOR.PATCH, e.g. 1.0.0",
            {.key = "--version"});
  wm::Check(train_episodes >= 0, "must be >= 0", {.key = "--train-episodes"});
  wm::Check(val_episodes >= 0, "must be >= 0", {.key = "--val-episodes"});
  wm::Check(train_episodes + val_episodes >= 1, "at least one episode is needed",
            {.key = "--train-episodes"});
  wm::Check(files >= 1 && files <= 99999, "must be in 1..99999", {.key = "--files"});
  wm::Check(size >= 64 && size <= 256,
            "image size " + std::to_string(size) + " is outside 64..256 pixels", {.key = "--size"});
  wm::Check(max_steps >= 1 && max_steps <= 1000, "must be in 1..1000", {.key = "--max-steps"});
  wm::Check(!policies.empty(), "at least one policy is needed", {.key = "--policies"});
  for (const std::string& p : policies) ParsePolicyKind(p);
  const GoalRegion& g = goal_region;
  const GoalRegion& b = kGoalRegionBounds;
  wm::Check(g.x_min >= b.x_min && g.x_max <= b.x_max && g.y_min >= b.y_min && g.y_max <= b.y_max,
            fmt::format("goal region x [{}, {}] y [{}, {}] must lie within x [{}, {}] y [{}, {}] "
                        "(metres; where the arm can carry the block)",
                        g.x_min, g.x_max, g.y_min, g.y_max, b.x_min, b.x_max, b.y_min, b.y_max),
            {.key = "--goal-region"});
  wm::Check(g.x_max - g.x_min >= kMinGoalRegionSide - 1e-12 &&
                g.y_max - g.y_min >= kMinGoalRegionSide - 1e-12,
            fmt::format("goal region x [{}, {}] y [{}, {}] must be at least {} m wide and deep",
                        g.x_min, g.x_max, g.y_min, g.y_max, kMinGoalRegionSide),
            {.key = "--goal-region"});
}

GoalRegion ParseGoalRegion(const std::string& text) {
  const std::string expected =
      "expected XMIN,XMAX,YMIN,YMAX in metres, e.g. 0.05,0.2,-0.05,0.35, got '" + text + "'";
  std::vector<double> v;
  size_t begin = 0;
  while (begin <= text.size()) {
    const size_t end = std::min(text.find(',', begin), text.size());
    const std::string field = text.substr(begin, end - begin);
    double value = 0;
    const auto [ptr, ec] = std::from_chars(field.data(), field.data() + field.size(), value);
    Check(!field.empty() && ec == std::errc() && ptr == field.data() + field.size() &&
              std::isfinite(value),
          expected, {.key = "--goal-region"});
    v.push_back(value);
    begin = end + 1;
  }
  Check(v.size() == 4, expected, {.key = "--goal-region"});
  Check(v[0] < v[1] && v[2] < v[3], "XMIN < XMAX and YMIN < YMAX are needed: " + expected,
        {.key = "--goal-region"});
  return {v[0], v[1], v[2], v[3]};
}

PolicyKind TabletopOptions::PolicyForEpisode(int64_t index) const {
  return ParsePolicyKind(policies[static_cast<size_t>(index) % policies.size()]);
}

void RemoveStaleShards(const std::string& dir, const std::string& name,
                       const std::set<std::string>& written) {
  const std::regex shard_name(name + "-[a-z0-9_]+\\.tfrecord-[0-9]{5}-of-[0-9]{5}");
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string file = entry.path().filename().string();
    if (std::regex_match(file, shard_name) && !written.count(file)) {
      spdlog::info("removing stale shard {} from an earlier run", file);
      if (!fs::remove(entry.path(), ec) || ec) {
        throw Error("cannot remove a stale shard: " + ec.message(),
                    {.file = entry.path().string()});
      }
    }
  }
  if (ec) throw Error("cannot list the dataset directory: " + ec.message(), {.file = dir});
}

TabletopSummary WriteTabletopDataset(const TabletopOptions& o) {
  o.Check();
  TabletopSummary summary;
  summary.dataset_dir = (fs::path(o.out_dir) / o.name / o.version).string();
  try {
    fs::create_directories(summary.dataset_dir);
  } catch (const fs::filesystem_error& e) {
    throw Error(std::string("cannot create the dataset directory: ") + e.what(),
                {.file = summary.dataset_dir});
  }
  std::vector<SplitPlan> plans;
  if (o.train_episodes > 0) plans.push_back({"train", o.train_episodes});
  if (o.val_episodes > 0) plans.push_back({"val", o.val_episodes});
  Progress progress("generating " + o.name, o.train_episodes + o.val_episodes, "episodes");
  std::vector<SplitInfo> infos;
  std::set<std::string> written;
  for (const SplitPlan& plan : plans) {
    SplitInfo info{plan.name, 0, ShardLengths(plan.episodes, o.files)};
    int64_t next = 0;
    const int shards = static_cast<int>(info.shard_lengths.size());
    for (int shard = 0; shard < shards; ++shard) {
      const std::string file = TfdsShardFileName(o.name, plan.name, shard, shards);
      rlds::TfRecordWriter writer((fs::path(summary.dataset_dir) / file).string());
      const int count = static_cast<int>(info.shard_lengths[shard]);
      // Chunks bound memory to a few episodes per thread however large a shard is.
      for (int done = 0; done < count;) {
        const int chunk = std::min(count - done, 16);
        const std::vector<Rollout> rollouts = RollOutAll(o, plan.name, next, chunk);
        const std::vector<std::string> examples = EncodeAll(rollouts, o.size);
        for (size_t i = 0; i < rollouts.size(); ++i) {
          writer.Write(examples[i]);
          info.num_bytes += examples[i].size() + 16;  // TFRecord framing: 8 + 4 + 4 bytes
          auto& [episodes, successes] = summary.by_policy[PolicyName(rollouts[i].policy)];
          ++episodes, successes += rollouts[i].success;
          summary.steps += static_cast<int64_t>(rollouts[i].steps.size());
          progress.Add();
        }
        next += chunk, done += chunk;
      }
      writer.Close();
      written.insert(file);
    }
    summary.episodes += plan.episodes;
    summary.bytes += info.num_bytes;
    infos.push_back(info);
  }
  progress.Finish();
  RemoveStaleShards(summary.dataset_dir, o.name, written);
  const fs::path dir(summary.dataset_dir);
  WriteFileAtomically((dir / "features.json").string(), TabletopFeaturesJson(o.size));
  WriteFileAtomically((dir / "dataset_info.json").string(),
                      DatasetInfoJson(o.name, o.version, Describe(o), infos));
  return summary;
}

}  // namespace wm::tabletop

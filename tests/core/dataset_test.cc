// Dataset directories: rolling shards, index.json, action statistics, verify, resume.
#include <gtest/gtest.h>

#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/shard/dataset_reader.h"
#include "core/shard/dataset_writer.h"
#include "tests/core/test_util.h"

namespace wm::shard {
namespace {
namespace fs = std::filesystem;
using test::MakeEpisode;

DatasetWriterOptions SmallShards(const std::string& dir) {
  return {.dir = dir, .shard_size_bytes = 2000, .zstd_level = 3, .config_hash = "cfg"};
}

DatasetIndex Meta() {
  DatasetIndex x;
  x.dataset = "unit";
  x.split = "train";
  return x;
}

// Writes episodes [0, n) and finishes.
DatasetIndex WriteAll(const std::string& dir, int n) {
  DatasetWriter w(SmallShards(dir));
  for (int i = 0; i < n; ++i) w.Add(MakeEpisode(4 + i % 3, i, "ep" + std::to_string(i)), i);
  return w.Finish(Meta());
}

TEST(ActionStats, MatchesHandComputedCase) {
  // Dimension 0 takes 1, 2, 3, 4; the others are constant 0.5.
  std::vector<float> actions;
  for (float v : {1.f, 2.f, 3.f, 4.f}) {
    actions.push_back(v);
    for (int d = 1; d < kActionDim; ++d) actions.push_back(0.5f);
  }
  ActionStats s = ComputeActionStats(actions);
  EXPECT_DOUBLE_EQ(s.mean[0], 2.5);
  EXPECT_DOUBLE_EQ(s.std[0], std::sqrt(1.25));  // population std
  EXPECT_DOUBLE_EQ(s.min[0], 1.0);
  EXPECT_DOUBLE_EQ(s.max[0], 4.0);
  EXPECT_DOUBLE_EQ(s.q01[0], 1.03);  // numpy: 1 + 0.01 * 3
  EXPECT_DOUBLE_EQ(s.q99[0], 3.97);
  EXPECT_DOUBLE_EQ(s.std[3], 0.0);
  EXPECT_DOUBLE_EQ(s.q99[6], 0.5);
}

TEST(Dataset, RollsShardsAndReadsEveryEpisodeBack) {
  test::TempDir dir;
  DatasetIndex index = WriteAll(dir.path(), 9);
  EXPECT_GT(index.shards.size(), 2u) << "2000-byte shards should roll several times";
  EXPECT_EQ(index.num_episodes, 9u);
  DatasetReader reader(dir.path());
  uint64_t steps = 0;
  for (size_t k = 0; k < 9; ++k) {
    Episode e = reader.ReadEpisode(k);
    Episode expected = MakeEpisode(4 + k % 3, k, "ep" + std::to_string(k));
    EXPECT_EQ(e.episode_key, expected.episode_key);
    EXPECT_EQ(e.actions, expected.actions);
    steps += e.num_steps;
  }
  EXPECT_EQ(reader.index().num_steps, steps);
  EXPECT_FALSE(fs::exists(dir / DatasetWriter::kStateFileName));
  EXPECT_EQ(VerifyDataset(dir.path()).episodes, 9u);
  EXPECT_THROW(reader.ReadEpisode(9), Error);
}

TEST(Dataset, IndexStatsEqualStatsOfAllActions) {
  test::TempDir dir;
  DatasetIndex index = WriteAll(dir.path(), 5);
  std::vector<float> all;
  for (int i = 0; i < 5; ++i) {
    Episode e = MakeEpisode(4 + i % 3, i);
    all.insert(all.end(), e.actions.begin(), e.actions.end());
  }
  ActionStats expected = ComputeActionStats(all);
  DatasetIndex reread = ReadIndex(dir.path());  // through JSON and back
  for (int d = 0; d < kActionDim; ++d) {
    EXPECT_DOUBLE_EQ(reread.action_stats.mean[d], expected.mean[d]);
    EXPECT_DOUBLE_EQ(reread.action_stats.q99[d], expected.q99[d]);
  }
}

TEST(Dataset, VerifyDetectsChangedShardAndIndexMismatch) {
  test::TempDir dir;
  DatasetIndex index = WriteAll(dir.path(), 4);
  std::string shard = dir / index.shards[0].file;
  test::FlipByte(shard, 20);
  EXPECT_THROW(
      {
        try {
          VerifyDataset(dir.path());
        } catch (const Error& e) {
          EXPECT_NE(std::string(e.what()).find("SHA-256"), std::string::npos) << e.what();
          throw;
        }
      },
      Error);
}

TEST(Dataset, RejectsUnknownIndexVersion) {
  test::TempDir dir;
  WriteAll(dir.path(), 2);
  std::string text = ReadFile(dir / "index.json");
  text.replace(text.find("\"format_version\": 1"), 19, "\"format_version\": 7");
  WriteFileAtomically(dir / "index.json", text);
  try {
    ReadIndex(dir.path());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("unknown format_version 7"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("index.json"), std::string::npos);
  }
}

TEST(Dataset, MissingIndexSaysInterrupted) {
  test::TempDir dir;
  try {
    DatasetReader reader(dir.path());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("index.json is missing"), std::string::npos);
  }
}

// A run killed after some shards resumes from the last finished shard and ends with the same
// bytes as an uninterrupted run, wherever the kill falls.
TEST(Dataset, ResumeAfterKillGivesIdenticalBytes) {
  test::TempDir whole;
  WriteAll(whole.path(), 9);
  bool lost_work_somewhere = false;
  for (int kill_after = 1; kill_after < 9; ++kill_after) {
    test::TempDir killed;
    {
      DatasetWriter w(SmallShards(killed.path()));
      for (int i = 0; i < kill_after; ++i)
        w.Add(MakeEpisode(4 + i % 3, i, "ep" + std::to_string(i)), i);
      // destroyed without Finish: the in-progress shard is lost, finished shards and state stay
    }
    DatasetWriter w(SmallShards(killed.path()));
    ASSERT_LE(w.resume_position(), static_cast<uint64_t>(kill_after));
    lost_work_somewhere |= w.resume_position() < static_cast<uint64_t>(kill_after);
    for (int i = static_cast<int>(w.resume_position()); i < 9; ++i) {
      w.Add(MakeEpisode(4 + i % 3, i, "ep" + std::to_string(i)), i);
    }
    w.Finish(Meta());
    size_t files = 0;
    for (const auto& e : fs::directory_iterator(whole.path())) {
      std::string name = e.path().filename();
      EXPECT_EQ(ReadFile(whole / name), ReadFile(killed / name)) << name << " kill " << kill_after;
      ++files;
    }
    EXPECT_EQ(std::distance(fs::directory_iterator(killed.path()), fs::directory_iterator()),
              static_cast<long>(files));
  }
  EXPECT_TRUE(lost_work_somewhere) << "no kill point interrupted an unfinished shard";
}

TEST(Dataset, ResumeIgnoresStateOfAnotherConfig) {
  test::TempDir dir;
  {
    DatasetWriter w(SmallShards(dir.path()));
    for (int i = 0; i < 6; ++i) w.Add(MakeEpisode(5, i), i);
  }
  auto options = SmallShards(dir.path());
  options.config_hash = "other";
  EXPECT_EQ(DatasetWriter(options).resume_position(), 0u);
}

}  // namespace
}  // namespace wm::shard

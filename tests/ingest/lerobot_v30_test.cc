// wm-ingest's LeRobot v3.0 reader on fixtures converted from the real v2.1 sample
// (../shared/samples/lerobot/unitree_g1_v21, episodes 1, 2, 4) at test time, laid out as LeRobot's
// convert_dataset_v21_to_v30.py does: several episodes per data file and per video file, episodes
// split across files, frames cut by from_timestamp / to_timestamp. Each v3.0 episode must equal
// the v2.1 original: same steps, same actions bit for bit, same instruction, same frames (the
// videos are remuxed, not re-encoded, so the decoded pixels and their JPEGs are identical).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "ingest/lerobot/lerobot_meta.h"
#include "ingest/lerobot/lerobot_source.h"
#include "tests/core/test_util.h"
#include "tests/ingest/lerobot_v30_fixture.h"

namespace wm::ingest {
namespace {
namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using testing::V30FixtureOptions;
using testing::WriteV30Fixture;

std::string SampleDir() { return test::SamplesDir() + "/lerobot/unitree_g1_v21"; }
std::string SourceDir() { return test::SourceDir(); }
std::string Mapping() { return SourceDir() + "/configs/lerobot/unitree_g1_v21.yaml"; }

#define REQUIRE_SAMPLE() \
  if (!fs::exists(SampleDir() + "/meta/info.json")) GTEST_SKIP() << "no sample at " << SampleDir()

class LeRobotV30 : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("wm_lerobot_v30_" + std::to_string(getpid()));
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Build(const V30FixtureOptions& options) {
    WriteV30Fixture(SampleDir(), dir_.string(), options);
    return dir_.string();
  }
  fs::path dir_;
};

TEST_F(LeRobotV30, MetaListsEpisodesTasksAndVideoSpans) {
  REQUIRE_SAMPLE();
  const LeRobotMeta m = ReadLeRobotMeta(Build({}));
  EXPECT_EQ(m.codebase_version, "v3.0");
  ASSERT_EQ(m.episodes.size(), 3u);
  EXPECT_EQ(m.tasks.at(0), "Pick up the yellow bottle on the table.");
  const LeRobotEpisodeMeta& e2 = m.Episode(2);
  EXPECT_EQ(m.DataPath(e2), "data/chunk-000/file-000.parquet");
  EXPECT_EQ(m.DataPath(m.Episode(4)), "data/chunk-000/file-001.parquet");
  EXPECT_EQ(m.VideoPath(e2, "observation.images.cam_high"),
            "videos/observation.images.cam_high/chunk-000/file-000.mp4");
  const LeRobotVideoSpan s1 = m.VideoSpan(m.Episode(1), "observation.images.cam_high"),
                         s2 = m.VideoSpan(e2, "observation.images.cam_high");
  EXPECT_EQ(s1.from_s, 0);
  EXPECT_EQ(s2.from_s, s1.to_s);  // concatenated
  EXPECT_NEAR(s2.to_s - s2.from_s, 343 / 30.0, 1e-3);
}

// Two layouts: episodes 1+2 | 4 in the data files with one video file of all three, and one data
// file with the video split 1 | 2+4.
TEST_F(LeRobotV30, EveryFrameAndActionEqualsTheV21Original) {
  REQUIRE_SAMPLE();
  LeRobotSource v21(SampleDir(), "", Mapping(), SourceDir() + "/configs");
  std::map<int64_t, Episode> original;
  for (const EpisodeRef& ref : v21.ListEpisodes(nullptr)) original[ref.record] = v21.Load(ref);
  V30FixtureOptions split_video;
  split_video.data_files = {{1, 2, 4}};
  split_video.video_files = {{1}, {2, 4}};
  for (const V30FixtureOptions& layout : {V30FixtureOptions{}, split_video}) {
    LeRobotSource v30(Build(layout), "", Mapping(), SourceDir() + "/configs");
    const std::vector<EpisodeRef> refs = v30.ListEpisodes(nullptr);
    ASSERT_EQ(refs.size(), 3u);
    EXPECT_TRUE(v30.Absent().empty());
    for (const EpisodeRef& ref : refs) {
      SCOPED_TRACE(ref.record);
      const Episode e = v30.Load(ref), &want = original.at(ref.record);
      ASSERT_EQ(e.num_steps, want.num_steps);
      EXPECT_EQ(e.actions, want.actions);  // float32 values copied: exact
      EXPECT_EQ(e.action_dim, 26);
      EXPECT_EQ(e.action_space, "joint_position");
      EXPECT_EQ(e.language_instruction, want.language_instruction);
      EXPECT_EQ(e.is_last, want.is_last);
      const auto& frames = e.images.at("image").frames;
      const auto& want_frames = want.images.at("image").frames;
      ASSERT_EQ(frames.size(), want_frames.size());
      for (size_t t = 0; t < frames.size(); ++t)
        ASSERT_EQ(frames[t], want_frames[t]) << "step " << t;
    }
  }
}

// The command line end to end: wm-ingest writes all three episodes of a v3.0 dataset.
TEST_F(LeRobotV30, WmIngestWritesEveryEpisode) {
  REQUIRE_SAMPLE();
  const std::string in = Build({}), out = (dir_ / "shards").string();
  const std::string cmd = test::BinDir() + "/wm-ingest --format lerobot --input " + in +
                          " --mapping " + Mapping() + " --output " + out +
                          " --resize 32x32 --log-level warn";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream index(out + "/index.json");
  const nlohmann::json j = nlohmann::json::parse(index);
  EXPECT_EQ(j["num_episodes"], 3) << j.dump(1).substr(0, 2000);
  EXPECT_EQ(j["num_steps"], 1093);
}

TEST_F(LeRobotV30, ToTimestampPastTheVideoEndIsAnError) {
  REQUIRE_SAMPLE();
  V30FixtureOptions o;
  o.extra_to_timestamp_s = 2.0;  // episode 4, the last of file-000.mp4
  LeRobotSource v30(Build(o), "", Mapping(), SourceDir() + "/configs");
  const std::vector<EpisodeRef> refs = v30.ListEpisodes(nullptr);
  EXPECT_THAT([&] { v30.Load(refs[2]); },
              ThrowsMessage<Error>(
                  AllOf(HasSubstr("videos/observation.images.cam_high/chunk-000/file-000.mp4"),
                        HasSubstr("episode 4"), HasSubstr("runs to to_timestamp"))));
}

TEST_F(LeRobotV30, EpisodeMissingFromItsDataFileIsAnError) {
  REQUIRE_SAMPLE();
  V30FixtureOptions o;
  o.misplaced_episode = 2;  // meta/episodes says file-001, which holds only episode 4
  LeRobotSource v30(Build(o), "", Mapping(), SourceDir() + "/configs");
  const std::vector<EpisodeRef> refs = v30.ListEpisodes(nullptr);
  ASSERT_EQ(refs[1].rel_path, "data/chunk-000/file-001.parquet");
  EXPECT_THAT([&] { v30.Load(refs[1]); },
              ThrowsMessage<Error>(AllOf(HasSubstr("data/chunk-000/file-001.parquet"),
                                         HasSubstr("episode 2 is not in this file"),
                                         HasSubstr("holds 4"))));
}

}  // namespace
}  // namespace wm::ingest

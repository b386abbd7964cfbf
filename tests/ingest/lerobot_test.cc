// wm-ingest's LeRobot reader on the real v2.1 sample (../shared/samples/lerobot/unitree_g1_v21:
// episodes 1, 2, 4 of 100, AV1 640x480, 26-dim joint actions). No independent Parquet reader
// exists on Debian 12 (no pyarrow / pandas), so decoded values are checked against numbers
// derived another way: frame_index = 0..T-1, timestamp = frame_index / fps, episode_index
// constant, and per-dimension action min / max / mean against meta/episodes_stats.jsonl, which
// LeRobot computed from the same rows. Plus the frame matcher and the mapping on their own.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/paths.h"
#include "ingest/image_codec.h"
#include "ingest/lerobot/frame_matcher.h"
#include "ingest/lerobot/lerobot_mapping.h"
#include "ingest/lerobot/lerobot_source.h"
#include "ingest/parquet/parquet_file.h"
#include "tests/core/test_util.h"

namespace wm::ingest {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string SampleDir() { return test::SamplesDir() + "/lerobot/unitree_g1_v21"; }

#define REQUIRE_SAMPLE() \
  if (!fs::exists(SampleDir() + "/meta/info.json")) GTEST_SKIP() << "no sample at " << SampleDir()

std::string ConfigsDir() { return std::string(std::getenv("WM_SOURCE_DIR")) + "/configs"; }

// meta/episodes_stats.jsonl's "action" stats of one episode.
nlohmann::json ActionStatsOf(int64_t episode) {
  std::ifstream in(SampleDir() + "/meta/episodes_stats.jsonl");
  std::string line;
  while (std::getline(in, line)) {
    auto j = nlohmann::json::parse(line);
    if (j["episode_index"] == episode) return j["stats"]["action"];
  }
  return nullptr;
}

TEST(LeRobotParquet, SampleValuesMatchWhatLeRobotRecorded) {
  REQUIRE_SAMPLE();
  for (int64_t episode : {1, 2, 4}) {
    SCOPED_TRACE(episode);
    char name[64];
    std::snprintf(name, sizeof(name), "/data/chunk-000/episode_%06lld.parquet",
                  static_cast<long long>(episode));
    parquet::ParquetFile f(SampleDir() + name);
    const int64_t t = f.num_rows();
    const parquet::Column frame = f.Read("frame_index"), ts = f.Read("timestamp"),
                          ep = f.Read("episode_index"), action = f.Read("action");
    for (int64_t i = 0; i < t; ++i) {
      ASSERT_EQ(frame.values.ints[i], i);
      ASSERT_NEAR(ts.values.reals[i], static_cast<double>(i) / 30.0, 1e-5);  // fps 30
      ASSERT_EQ(ep.values.ints[i], episode);
      ASSERT_EQ(action.RowSize(i), 26);
    }
    const nlohmann::json stats = ActionStatsOf(episode);
    ASSERT_EQ(stats["count"][0].get<int64_t>(), t);
    for (int d = 0; d < 26; ++d) {
      double lo = 1e30, hi = -1e30, sum = 0;
      for (int64_t i = 0; i < t; ++i) {
        const double v = action.values.reals[i * 26 + d];
        lo = std::min(lo, v), hi = std::max(hi, v), sum += v;
      }
      EXPECT_EQ(lo, stats["min"][d].get<double>()) << "dim " << d;  // float32 values: exact
      EXPECT_EQ(hi, stats["max"][d].get<double>()) << "dim " << d;
      EXPECT_NEAR(sum / t, stats["mean"][d].get<double>(), 1e-6) << "dim " << d;
    }
  }
}

TEST(LeRobotSource, ListsThePresentEpisodesAndReportsTheAbsent) {
  REQUIRE_SAMPLE();
  LeRobotSource source(SampleDir(), "", "", ConfigsDir());
  const std::vector<EpisodeRef> refs = source.ListEpisodes(nullptr);
  ASSERT_EQ(refs.size(), 3u);
  EXPECT_EQ(refs[0].record, 1);
  EXPECT_EQ(refs[1].record, 2);
  EXPECT_EQ(refs[2].record, 4);
  EXPECT_EQ(refs[2].rel_path, "data/chunk-000/episode_000004.parquet");
  const auto absent = source.Absent();
  ASSERT_EQ(absent.size(), 97u);
  EXPECT_EQ(absent[0].record, 0);
  EXPECT_THAT(absent[0].reason, HasSubstr("episode_000000.parquet does not exist"));
  EXPECT_EQ(source.Describe()["mapping"]["action_space"], "joint_position");  // unitree_g1_v21.yaml
}

// One whole episode: every step gets its frame, the action keeps its 26 dimensions.
TEST(LeRobotSource, LoadsAnEpisodeWithEveryFrameAndAction) {
  REQUIRE_SAMPLE();
  LeRobotSource source(SampleDir(), "observation.images.cam_high", "", ConfigsDir());
  const std::vector<EpisodeRef> refs = source.ListEpisodes(nullptr);
  const Episode e = source.Load(refs[1]);  // episode 2: 343 steps
  EXPECT_EQ(e.episode_key, "data/chunk-000/episode_000002.parquet#2");
  EXPECT_EQ(e.num_steps, 343);
  EXPECT_EQ(e.action_dim, 26);
  EXPECT_EQ(e.action_space, "joint_position");
  EXPECT_EQ(e.actions.size(), 343u * 26);
  EXPECT_EQ(e.language_instruction, "Pick up the yellow bottle on the table.");
  const EncodedFrames& image = e.images.at("image");
  ASSERT_EQ(image.frames.size(), 343u);
  for (const auto& f : image.frames) ASSERT_EQ(SniffEncoding(f), "jpeg");
  const ImageInfo info = DecodeInfo(image.frames.back());
  EXPECT_EQ(info.height, 480);
  EXPECT_EQ(info.width, 640);
  EXPECT_NE(image.frames.front(), image.frames.back());  // the robot moves
  EXPECT_TRUE(e.is_last.back());
}

TEST(LeRobotSource, UnknownCameraIsAnErrorListingTheVideoFeatures) {
  REQUIRE_SAMPLE();
  EXPECT_THAT([&] { LeRobotSource(SampleDir(), "observation.images.wrist", "", ConfigsDir()); },
              ThrowsMessage<Error>(HasSubstr("(observation.images.cam_high)")));
}

TEST(FrameMatcher, PairsStepsWithTheNearestFrameWithinTolerance) {
  FrameMatcher m({0.0, 1.0 / 30, 2.0 / 30}, 1e-4);
  EXPECT_THAT(m.Offer(0.0), ::testing::ElementsAre(0u));
  EXPECT_TRUE(m.Offer(0.5 / 30).empty());  // between steps: nobody's frame
  EXPECT_THAT(m.Offer(1.0 / 30 + 5e-5), ::testing::ElementsAre(1u));
  EXPECT_THAT(m.Offer(1.0 / 30), ::testing::ElementsAre(1u));   // nearer still: replaces
  EXPECT_THROW(m.CheckAllMatched(), Error);                     // step 2 has none yet
  EXPECT_THAT(m.Offer(2.0 / 30 + 2e-4), ::testing::IsEmpty());  // outside 1e-4
  EXPECT_THAT([&] { m.CheckAllMatched(); },
              ThrowsMessage<Error>(HasSubstr("step 2 (timestamp 0.066667 s) has no video frame "
                                             "within 0.000100 s (nearest frame at 0.066867 s)")));
}

TEST(LeRobotMapping, RefusesAnUnknownActionSpaceAndKey) {
  const fs::path dir = fs::temp_directory_path() / "wm_lerobot_mapping_test";
  fs::create_directories(dir);
  std::ofstream(dir / "bad.yaml") << "action: actions\naction_space: joints\n";
  EXPECT_THAT([&] { LoadLeRobotMapping((dir / "bad.yaml").string()); },
              ThrowsMessage<Error>(AllOf(HasSubstr("key 'action_space'"),
                                         HasSubstr("eef_delta, joint_position or other"))));
  std::ofstream(dir / "typo.yaml") << "acton: actions\n";
  EXPECT_THROW(LoadLeRobotMapping((dir / "typo.yaml").string()), Error);
  std::ofstream(dir / "ok.yaml") << "action: actions\nstate: null\ncamera: image\n";
  const LeRobotMapping m = LoadLeRobotMapping((dir / "ok.yaml").string());
  EXPECT_EQ(m.action, "actions");
  EXPECT_FALSE(m.state.has_value());
  EXPECT_EQ(m.timestamp, "timestamp");
  EXPECT_EQ(m.tolerance_s, 1e-4);
  fs::remove_all(dir);
}

TEST(LeRobotMeta, FormatsPathTemplates) {
  EXPECT_EQ(
      FormatPathTemplate("videos/chunk-{episode_chunk:03d}/{video_key}/episode_"
                         "{episode_index:06d}.mp4",
                         {{"video_key", "cam"}}, {{"episode_chunk", 2}, {"episode_index", 2041}}),
      "videos/chunk-002/cam/episode_002041.mp4");
  EXPECT_THROW(FormatPathTemplate("{nope}", {}, {}), Error);
}

}  // namespace
}  // namespace wm::ingest

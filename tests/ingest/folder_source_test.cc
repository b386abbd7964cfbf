// FolderSource against episode folders written here (cv::imwrite frames, CSV, meta.json).
#include "ingest/folder/folder_source.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <utility>

#include "core/error.h"
#include "tests/core/test_util.h"

namespace wm::ingest {
namespace {
namespace fs = std::filesystem;

using test::ErrorText;

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

std::string ReadBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// An 8x8 frame whose every pixel is `value`, so that frame order is visible in the bytes.
void WriteFrame(const fs::path& path, int value) {
  ASSERT_TRUE(cv::imwrite(path.string(), cv::Mat(8, 8, CV_8UC3, cv::Scalar::all(value))));
}

// dataset/ep_2: 3 PNG frames named 1, 2, 10 (natural order differs from lexicographic), a CSV
// header with a CRLF row, rewards and meta.json. dataset/ep_10: 2 JPEG frames, nothing optional.
class FolderSourceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(ep2_);
    fs::create_directories(ep10_);
    fs::create_directories(root_ / ".cache");  // hidden: not an episode
    WriteFrame(ep2_ / "frame_1.png", 10);
    WriteFrame(ep2_ / "frame_2.png", 20);
    WriteFrame(ep2_ / "frame_10.png", 100);
    WriteText(ep2_ / "notes.txt", "ignored");
    WriteText(ep2_ / "actions.csv",
              "dx,dy,dz,droll,dpitch,dyaw,gripper\n"
              "0.1,0.2,0.3,0.4,0.5,0.6,1\r\n"
              " -1, +2 ,3e-1,0,0,0,0\n"
              "7,6,5,4,3,2,1\n\n");
    WriteText(ep2_ / "rewards.csv", "0\n0.5\n1\n");
    WriteText(ep2_ / "meta.json",
              R"({"language_instruction": "open the drawer", "policy_id": "diffusion-v2",
                  "episode_seed": 42, "terminal": true, "operator": "ignored"})");
    WriteFrame(ep10_ / "0.jpg", 50);
    WriteFrame(ep10_ / "1.jpeg", 60);
    WriteText(ep10_ / "actions.csv", "1,1,1,1,1,1,1\n2,2,2,2,2,2,2\n");
  }

  test::TempDir dir_;
  fs::path root_ = dir_.path() / "my_dataset";
  fs::path ep2_ = root_ / "ep_2";
  fs::path ep10_ = root_ / "ep_10";
};

TEST_F(FolderSourceTest, ListsEpisodeFoldersInNaturalOrder) {
  FolderSource source(root_.string());
  EXPECT_EQ(source.format(), "folder");
  EXPECT_EQ(source.dataset_name(), "my_dataset");
  std::vector<EpisodeRef> refs = source.ListEpisodes(nullptr);
  ASSERT_EQ(refs.size(), 2u);
  EXPECT_EQ(refs[0].rel_path, "ep_2");
  EXPECT_EQ(refs[0].path, ep2_.string());
  EXPECT_EQ(refs[0].record, 0);
  EXPECT_EQ(refs[1].rel_path, "ep_10");
}

TEST_F(FolderSourceTest, LoadsFramesAsStoredWithCsvAndMeta) {
  FolderSource source(root_.string());
  Episode ep = source.Load({ep2_.string(), "ep_2", 0});
  EXPECT_EQ(ep.episode_key, "ep_2#0");
  EXPECT_EQ(ep.source_file, "ep_2");
  EXPECT_EQ(ep.source_record, 0);
  EXPECT_EQ(ep.language_instruction, "open the drawer");
  EXPECT_EQ(ep.policy_id, "diffusion-v2");
  EXPECT_EQ(ep.episode_seed, 42);
  ASSERT_EQ(ep.num_steps, 3);

  const EncodedFrames& image = ep.images.at("image");
  EXPECT_EQ(image.encoding, "png");
  EXPECT_EQ(image.height, 8);
  EXPECT_EQ(image.width, 8);
  EXPECT_EQ(image.channels, 3);
  ASSERT_EQ(image.frames.size(), 3u);
  EXPECT_EQ(image.frames[0], ReadBytes(ep2_ / "frame_1.png"));  // bytes kept, natural order
  EXPECT_EQ(image.frames[1], ReadBytes(ep2_ / "frame_2.png"));
  EXPECT_EQ(image.frames[2], ReadBytes(ep2_ / "frame_10.png"));

  std::vector<float> actions{0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f, 1, -1, 2, 0.3f, 0,
                             0,    0,    0,    7,    6,    5,    4, 3,  2, 1};
  EXPECT_EQ(ep.actions, actions);
  EXPECT_EQ((std::pair{ep.action_dim, ep.action_space}),
            (std::pair<int64_t, std::string>{7, "eef_delta"}));  // 7 wide: the canonical action
  EXPECT_EQ(ep.rewards, (std::vector<float>{0, 0.5f, 1}));
  EXPECT_EQ(ep.discounts, (std::vector<float>{1, 1, 1}));
  EXPECT_EQ(ep.is_first, (std::vector<uint8_t>{1, 0, 0}));
  EXPECT_EQ(ep.is_last, (std::vector<uint8_t>{0, 0, 1}));
  EXPECT_EQ(ep.is_terminal, (std::vector<uint8_t>{0, 0, 1}));  // meta.json "terminal": true
}

TEST_F(FolderSourceTest, OptionalFilesDefault) {
  Episode ep = FolderSource(root_.string()).Load({ep10_.string(), "ep_10", 0});
  EXPECT_EQ(ep.images.at("image").encoding, "jpeg");
  EXPECT_EQ(ep.images.at("image").frames[1], ReadBytes(ep10_ / "1.jpeg"));
  EXPECT_EQ(ep.rewards, (std::vector<float>{0, 0}));
  EXPECT_EQ(ep.is_last, (std::vector<uint8_t>{0, 1}));
  EXPECT_EQ(ep.is_terminal, (std::vector<uint8_t>{0, 0}));
  EXPECT_EQ(ep.language_instruction, "");
  EXPECT_EQ(ep.policy_id, "");
  EXPECT_FALSE(ep.episode_seed.has_value());
}

class FolderSourceErrors : public FolderSourceTest {
 protected:
  std::string LoadError() {
    return ErrorText([&] { FolderSource(root_.string()).Load({ep10_.string(), "ep_10", 0}); });
  }
  void ExpectIn(const std::string& what, const std::vector<std::string>& parts) {
    for (const auto& part : parts) EXPECT_NE(what.find(part), std::string::npos) << what;
  }
  std::string actions_ = (ep10_ / "actions.csv").string();
};

TEST_F(FolderSourceErrors, RowCountMismatch) {
  WriteText(actions_, "1,1,1,1,1,1,1\n");
  ExpectIn(LoadError(), {actions_, "has 1 action rows but the episode has 2 frames"});
  WriteText(ep10_ / "rewards.csv", "1\n2\n3\n");
  WriteText(actions_, "1,1,1,1,1,1,1\n2,2,2,2,2,2,2\n");
  ExpectIn(LoadError(), {(ep10_ / "rewards.csv").string(), "has 3 rewards"});
}

TEST_F(FolderSourceErrors, BadNumbersNameFileAndLine) {
  WriteText(actions_, "1,1,1,1,1,1,1\n2,abc,2,2,2,2,2\n");
  ExpectIn(LoadError(), {actions_, "line 2", "'abc' is not a number"});
  WriteText(actions_, "1,1,1,1,1,1,1\n2,2,2,2,2,2,1.5x\n");  // a prefix number is not enough
  ExpectIn(LoadError(), {actions_, "line 2", "'1.5x' is not a number"});
  WriteText(actions_, "x,y,z,r,p,yaw,g\n1,1,1,1,1,1\n2,2,2,2,2,2,2\n");
  ExpectIn(LoadError(),
           {actions_, "line 3", "expected 6 comma-separated values (as in the first row), got 7"});
  WriteText(actions_, "1,1,1,1,1,1,1\nx,y,z,r,p,yaw,g\n");  // only the first row may be a header
  ExpectIn(LoadError(), {actions_, "line 2", "'x' is not a number"});
}

TEST_F(FolderSourceTest, ActionsOfAnotherWidthKeepItInTheSpaceGiven) {
  WriteText(ep10_ / "actions.csv", "a0,a1,a2\n1,2,3\n4,5,6\n");
  const EpisodeRef ref{ep10_.string(), "ep_10", 0};
  Episode ep = FolderSource(root_.string()).Load(ref);
  EXPECT_EQ((std::pair{ep.action_dim, ep.action_space}),
            (std::pair<int64_t, std::string>{3, "other"}));
  EXPECT_EQ(ep.actions, (std::vector<float>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(FolderSource(root_.string(), "joint_position").Load(ref).action_space,
            "joint_position");
  const std::string what = ErrorText([&] { FolderSource(root_.string(), "eef_delta").Load(ref); });
  for (const char* part : {"actions.csv", "eef_delta actions are 7 values per step", "got 3"}) {
    EXPECT_NE(what.find(part), std::string::npos) << what;
  }
  EXPECT_EQ(FolderSource(root_.string()).Describe(), nlohmann::json::object());
  EXPECT_EQ(FolderSource(root_.string(), "other").Describe()["action_space"], "other");
}

// A 7-DoF arm's joint targets are 7 wide too: only meta.json (as wm-eval --save-rollouts writes
// it) or --action-space can tell them from end-effector deltas.
TEST_F(FolderSourceTest, MetaSaysTheActionSpaceAndTheFlagOutranksIt) {
  const EpisodeRef ref{ep10_.string(), "ep_10", 0};
  EXPECT_EQ(FolderSource(root_.string()).Load(ref).action_space, "eef_delta");  // inferred
  WriteText(ep10_ / "meta.json", R"({"action_space": "joint_position"})");
  Episode ep = FolderSource(root_.string()).Load(ref);
  EXPECT_EQ((std::pair{ep.action_dim, ep.action_space}),
            (std::pair<int64_t, std::string>{7, "joint_position"}));
  EXPECT_EQ(FolderSource(root_.string(), "other").Load(ref).action_space, "other");
  WriteText(ep10_ / "meta.json", R"({"action_space": "eef_delta"})");
  WriteText(ep10_ / "actions.csv", "1,2\n3,4\n");
  const std::string what = ErrorText([&] { FolderSource(root_.string()).Load(ref); });
  for (const char* part : {"actions.csv", "eef_delta actions are 7 values per step", "got 2"}) {
    EXPECT_NE(what.find(part), std::string::npos) << what;
  }
}

TEST_F(FolderSourceErrors, MissingActionsAndBadMeta) {
  fs::remove(actions_);
  ExpectIn(LoadError(), {ep10_.string(), "no actions.csv"});
  WriteText(actions_, "1,1,1,1,1,1,1\n2,2,2,2,2,2,2\n");
  WriteText(ep10_ / "meta.json", R"({"episode_seed": "seven"})");
  ExpectIn(LoadError(), {(ep10_ / "meta.json").string(), "key 'episode_seed'", "an integer"});
  WriteText(ep10_ / "meta.json", "{not json");
  ExpectIn(LoadError(), {(ep10_ / "meta.json").string(), "not a JSON object"});
  WriteText(ep10_ / "meta.json", R"({"action_space": "joints"})");
  ExpectIn(LoadError(), {(ep10_ / "meta.json").string(), "key 'action_space'",
                         "eef_delta, joint_position or other, got 'joints'"});
}

TEST_F(FolderSourceErrors, BadFramesAndInputs) {
  WriteText(ep10_ / "2.png", "not a png");
  ExpectIn(LoadError(), {(ep10_ / "2.png").string(), "neither JPEG nor PNG"});
  fs::remove(ep10_ / "2.png");
  fs::remove(ep10_ / "0.jpg");
  fs::remove(ep10_ / "1.jpeg");
  ExpectIn(LoadError(), {ep10_.string(), "no frames"});
  std::string missing = (dir_.path() / "nope").string();
  ExpectIn(ErrorText([&] { FolderSource(missing).ListEpisodes(nullptr); }),
           {missing, "not a directory"});
}

}  // namespace
}  // namespace wm::ingest

// wm-ingest --suggest-mapping: the printed YAML loads back through the mapping loaders, on the
// real samples in ../shared/samples (bridge_dataset and fractal RLDS, unitree_g1 LeRobot v2.1)
// and on a LeRobot v3.0 fixture converted from the latter; where the repo has a hand-written
// mapping, the guess equals it. A synthetic info.json checks the uncertain cases.
#include "ingest/suggest_mapping.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "ingest/lerobot/lerobot_mapping.h"
#include "ingest/rlds/dataset_mapping.h"
#include "ingest/rlds/tfds_dataset.h"
#include "tests/core/test_util.h"
#include "tests/ingest/lerobot_v30_fixture.h"

namespace wm::ingest {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

fs::path Samples() { return test::SamplesDir(); }
fs::path Configs() { return fs::path(test::SourceDir()) / "configs"; }

#define REQUIRE(path) \
  if (!fs::exists(path)) GTEST_SKIP() << "no sample at " << (path)

// Saves the suggestion where a user would and returns the file.
std::string Save(const std::string& yaml, const std::string& name) {
  const fs::path file =
      fs::temp_directory_path() / ("wm_suggest_" + std::to_string(getpid()) + "_" + name);
  std::ofstream(file) << yaml;
  return file.string();
}

int ActionWidth(const rlds::DatasetMapping& m, const rlds::TfdsDataset& d) {
  int width = 0;
  for (const auto& part : m.action) {
    width +=
        part.Width(part.key.empty() ? 0 : static_cast<int>(d.features.at(part.key).ElementSize()));
  }
  return width;
}

TEST(SuggestMapping, FractalGuessEqualsTheHandWrittenMapping) {
  const fs::path dir = Samples() / "rlds/fractal20220817_data";
  REQUIRE(dir);
  const std::string file = Save(SuggestMapping("rlds", dir.string()), "fractal.yaml");
  const rlds::DatasetMapping guess = rlds::LoadDatasetMapping(file);
  rlds::DatasetMapping want =
      rlds::LoadDatasetMapping((Configs() / "datasets/fractal20220817_data.yaml").string());
  want.file = guess.file;
  EXPECT_EQ(guess.ToJson(), want.ToJson());
  EXPECT_EQ(ActionWidth(guess, rlds::OpenTfdsDataset(dir.string())), 7);
  fs::remove(file);
}

TEST(SuggestMapping, BridgeGuessLoadsAndMarksTheCameraUncertain) {
  const fs::path dir = Samples() / "rlds/bridge_dataset";
  REQUIRE(dir);
  const std::string yaml = SuggestMapping("rlds", dir.string());
  EXPECT_THAT(yaml, HasSubstr("# UNCERTAIN camera: 4 cameras"));
  EXPECT_THAT(yaml, HasSubstr("# UNCERTAIN action: one 7-value tensor steps/action"));
  const std::string file = Save(yaml, "bridge.yaml");
  const rlds::DatasetMapping m = rlds::LoadDatasetMapping(file);
  EXPECT_EQ(m.dataset, "bridge_dataset");
  EXPECT_EQ(m.image, "steps/observation/image_0");
  ASSERT_EQ(m.action.size(), 1u);
  EXPECT_EQ(m.action[0].key, "steps/action");
  EXPECT_EQ(m.language_instruction, "steps/language_instruction");
  EXPECT_EQ(ActionWidth(m, rlds::OpenTfdsDataset(dir.string())), 7);
  fs::remove(file);
}

// Bridge's spec with its one steps/action tensor made 10 wide (as its own description says it
// is: joint velocities, gripper velocities, terminate): kept whole as `other`, with the words.
TEST(SuggestMapping, RldsActionOfAnotherWidthIsKeptWholeAsOther) {
  const fs::path bridge = Samples() / "rlds/bridge_dataset/1.0.0";
  REQUIRE(bridge);
  const test::TempDir temp;  // removed however the test ends
  const fs::path& dir = temp.path();
  fs::copy_file(bridge / "dataset_info.json", dir / "dataset_info.json");
  std::ifstream in(bridge / "features.json");
  nlohmann::json spec = nlohmann::json::parse(in);
  spec["featuresDict"]["features"]["steps"]["sequence"]["feature"]["featuresDict"]["features"]
      ["action"]["tensor"]["shape"]["dimensions"] = {"10"};
  std::ofstream(dir / "features.json") << spec.dump();

  const std::string yaml = SuggestMapping("rlds", dir.string());
  EXPECT_THAT(yaml, HasSubstr("# UNCERTAIN action: one 10-value tensor steps/action; kept whole "
                              "as action_space other"));
  EXPECT_THAT(yaml, HasSubstr("the dataset says: 'Robot action, consists of [7x joint "
                              "velocities, 2x gripper velocities, 1x terminate episode].'"));
  const std::string file = Save(yaml, "bridge10.yaml");
  const rlds::DatasetMapping m = rlds::LoadDatasetMapping(file);
  EXPECT_EQ(m.action_space, "other");
  EXPECT_EQ(ActionWidth(m, rlds::OpenTfdsDataset(dir.string())), 10);
  fs::remove(file);
}

// The G1 guess is configs/lerobot/unitree_g1_v21.yaml, for the v2.1 sample and its v3.0 copy.
TEST(SuggestMapping, UnitreeGuessEqualsTheHandWrittenMappingInV21AndV30) {
  const fs::path dir = Samples() / "lerobot/unitree_g1_v21";
  REQUIRE(dir / "meta/info.json");
  const fs::path v30 = fs::temp_directory_path() / ("wm_suggest_v30_" + std::to_string(getpid()));
  testing::WriteV30Fixture(dir.string(), v30.string());
  LeRobotMapping want = LoadLeRobotMapping((Configs() / "lerobot/unitree_g1_v21.yaml").string());
  for (const fs::path& root : {dir, v30}) {
    const std::string yaml = SuggestMapping("lerobot", root.string());
    EXPECT_THAT(yaml, HasSubstr("in this order: kLeftShoulderPitch, kLeftShoulderRoll"));
    EXPECT_THAT(yaml, HasSubstr("# UNCERTAIN action_space: joint names"));
    const std::string file = Save(yaml, "g1.yaml");
    const LeRobotMapping guess = LoadLeRobotMapping(file);
    EXPECT_EQ(guess.ToJson(), want.ToJson()) << yaml;
    fs::remove(file);
  }
  fs::remove_all(v30);
}

TEST(SuggestMapping, LeRobotWithTwoCamerasAndDeltaNamesSaysSo) {
  const fs::path root = fs::temp_directory_path() / ("wm_suggest_info_" + std::to_string(getpid()));
  fs::create_directories(root / "meta");
  std::ofstream(root / "meta/info.json") << R"({"codebase_version": "v3.0", "fps": 10, "features": {
    "observation.images.wrist": {"dtype": "video", "shape": [96, 96, 3]},
    "observation.images.front": {"dtype": "video", "shape": [96, 96, 3]},
    "actions": {"dtype": "float32", "shape": [7],
                "names": ["delta_x", "delta_y", "delta_z", "delta_roll", "delta_pitch", "delta_yaw", "gripper"]},
    "state": {"dtype": "float32", "shape": [8]},
    "next.reward": {"dtype": "float32", "shape": [1]},
    "timestamp": {"dtype": "float32", "shape": [1]}}})";
  const std::string yaml = SuggestMapping("lerobot", root.string());
  EXPECT_THAT(yaml, HasSubstr("# UNCERTAIN camera: 2 cameras"));
  EXPECT_THAT(yaml, HasSubstr("# UNCERTAIN frame_index: info.json declares no such feature"));
  const LeRobotMapping m = LoadLeRobotMapping(Save(yaml, "info.yaml"));
  EXPECT_EQ(m.camera, "observation.images.wrist");
  EXPECT_EQ(m.action, "actions");
  EXPECT_EQ(m.action_space, "eef_delta");
  EXPECT_EQ(m.state, "state");
  EXPECT_EQ(m.reward, "next.reward");
  EXPECT_FALSE(m.is_terminal.has_value());
  EXPECT_THAT([&] { SuggestMapping("hdf5", root.string()); },
              ThrowsMessage<Error>(HasSubstr("rlds and lerobot")));
  fs::remove_all(root);
}

}  // namespace
}  // namespace wm::ingest

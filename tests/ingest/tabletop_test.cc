// Tests for the synthetic tabletop generator: TFDS metadata layout, byte determinism, the
// episode records read back through wm::rlds, renderer consistency and policy skill.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <tuple>

#include "core/atomic_file.h"
#include "core/error.h"
#include "ingest/rlds/example.h"
#include "ingest/rlds/tfrecord.h"
#include "ingest/tabletop/episode.h"
#include "ingest/tabletop/render.h"
#include "ingest/tabletop/tabletop_writer.h"
#include "ingest/tabletop/tfds_features.h"

namespace fs = std::filesystem;
using namespace wm::tabletop;

namespace {

class ScratchDir {
 public:
  ScratchDir() {
    static int counter = 0;
    path_ = fs::temp_directory_path() /
            ("wm-tabletop-test-" + std::to_string(getpid()) + "-" + std::to_string(counter++));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~ScratchDir() { fs::remove_all(path_); }
  std::string str() const { return path_.string(); }

 private:
  fs::path path_;
};

TabletopOptions SmallOptions(const std::string& out) {
  TabletopOptions o;
  o.out_dir = out;
  o.train_episodes = 6;
  o.val_episodes = 3;
  o.size = 64;
  o.max_steps = 12;
  o.seed = 7;
  return o;
}

std::map<std::string, std::string> DirBytes(const std::string& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::directory_iterator(dir)) {
    files[e.path().filename().string()] = wm::ReadFile(e.path().string());
  }
  return files;
}

// All records of a split, in file order.
std::vector<std::string> SplitRecords(const std::string& dir, const std::string& split) {
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.find("-" + split + ".tfrecord-") != std::string::npos) files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  std::vector<std::string> records;
  for (const std::string& f : files) {
    wm::rlds::TfRecordReader reader(f);
    for (size_t k = 0; k < reader.num_records(); ++k) records.emplace_back(reader.Record(k));
  }
  return records;
}

cv::Mat Decode(const std::string& bytes) {
  return cv::imdecode(std::vector<uint8_t>(bytes.begin(), bytes.end()), cv::IMREAD_UNCHANGED);
}

int CountLabel(const Frame& f, uint8_t label) {
  return static_cast<int>(std::count(f.labels.begin(), f.labels.end(), label));
}

// A fixed, fully visible layout: gripper hovering between block and goal.
Scene FixedScene() {
  Rng rng(3);
  Scene scene = SampleScene(rng);
  scene.state.ee = {0.0, 0.12, 0.08};
  scene.state.ee_rpy = {0, 0, 0.3};
  scene.state.block = {0.1, 0.15, kBlockHalfSize};
  scene.state.goal = {-0.12, 0.2, 0};
  return scene;
}

std::string SampleDir() {
  const char* shared = std::getenv("WM_SHARED_DIR");
  return std::string(shared ? shared : "/work/shared") + "/samples/rlds/fractal20220817_data/0.1.0";
}

}  // namespace

TEST(TabletopTfds, SerializerReproducesTheRealTfdsFilesByteForByte) {
  // Our JSON comes from nlohmann dump(2) (ordered for features.json, sorted for
  // dataset_info.json); re-serializing the real TFDS-written files that way must not change a byte.
  if (!fs::exists(SampleDir())) GTEST_SKIP() << "no TFDS sample at " << SampleDir();
  const std::string features = wm::ReadFile(SampleDir() + "/features.json");
  EXPECT_EQ(nlohmann::ordered_json::parse(features).dump(2), features);
  const std::string info = wm::ReadFile(SampleDir() + "/dataset_info.json");
  EXPECT_EQ(nlohmann::json::parse(info).dump(2), info);
  // Same feature classes serialize identically to the sample's (e.g. Scalar bool).
  const auto ours = nlohmann::ordered_json::parse(TabletopFeaturesJson(128));
  const auto theirs = nlohmann::ordered_json::parse(features);
  const auto& our_steps = ours["featuresDict"]["features"]["steps"];
  const auto& their_steps = theirs["featuresDict"]["features"]["steps"];
  EXPECT_EQ(our_steps["pythonClassName"], their_steps["pythonClassName"]);
  EXPECT_EQ(our_steps["sequence"]["length"], their_steps["sequence"]["length"]);
  for (const char* key : {"is_first", "is_last", "is_terminal", "reward"}) {
    EXPECT_EQ(our_steps["sequence"]["feature"]["featuresDict"]["features"][key],
              their_steps["sequence"]["feature"]["featuresDict"]["features"][key])
        << key;
  }
}

TEST(TabletopTfds, FeaturesJsonDeclaresEveryKeyWithItsTfdsClass) {
  const auto j = nlohmann::json::parse(TabletopFeaturesJson(96));
  const auto& top = j["featuresDict"]["features"];
  const auto& steps = top["steps"]["sequence"]["feature"]["featuresDict"]["features"];
  const auto& obs = steps["observation"]["featuresDict"]["features"];
  const auto& meta = top["episode_metadata"]["featuresDict"]["features"];
  const std::string p = "tensorflow_datasets.core.features.";
  auto dims = [](const std::vector<std::string>& d) { return nlohmann::json{{"dimensions", d}}; };
  EXPECT_EQ(obs["image"]["pythonClassName"], p + "image_feature.Image");
  EXPECT_EQ(obs["image"]["image"]["shape"], dims({"96", "96", "3"}));
  EXPECT_EQ(obs["image"]["image"]["encodingFormat"], "jpeg");
  EXPECT_EQ(obs["depth"]["image"]["shape"], dims({"96", "96", "1"}));
  EXPECT_EQ(obs["depth"]["image"]["dtype"], "uint16");
  EXPECT_EQ(obs["depth"]["image"]["encodingFormat"], "png");
  EXPECT_EQ(obs["segmentation"]["image"]["dtype"], "uint8");
  EXPECT_EQ(steps["action"]["pythonClassName"], p + "tensor_feature.Tensor");
  EXPECT_EQ(steps["action"]["tensor"]["shape"], dims({"7"}));
  EXPECT_EQ(steps["discount"]["pythonClassName"], p + "scalar.Scalar");
  EXPECT_EQ(steps["is_terminal"]["tensor"]["dtype"], "bool");
  EXPECT_EQ(steps["language_instruction"]["pythonClassName"], p + "text_feature.Text");
  EXPECT_EQ(meta["policy_id"]["pythonClassName"], p + "text_feature.Text");
  EXPECT_EQ(meta["episode_seed"]["tensor"]["dtype"], "int64");
  EXPECT_EQ(meta["camera_intrinsics"]["tensor"]["shape"], dims({"4"}));
  EXPECT_EQ(TabletopFeatureKeys().size(), 13u);
}

TEST(TabletopWriter, SameOptionsGiveIdenticalBytesAndEpisodesDoNotDependOnFileCount) {
  ScratchDir a, b, c;
  TabletopOptions o = SmallOptions(a.str());
  WriteTabletopDataset(o);
  o.out_dir = b.str();
  WriteTabletopDataset(o);
  const std::string rel = "/wm_tabletop/1.0.0";
  const auto bytes_a = DirBytes(a.str() + rel);
  EXPECT_EQ(bytes_a, DirBytes(b.str() + rel));
  EXPECT_EQ(bytes_a.size(), 6u);  // 2 JSON files + 2 train + 2 val shards
  o.out_dir = c.str();
  o.files = 3;
  WriteTabletopDataset(o);
  EXPECT_EQ(SplitRecords(a.str() + rel, "train"), SplitRecords(c.str() + rel, "train"));
  EXPECT_EQ(SplitRecords(a.str() + rel, "val"), SplitRecords(c.str() + rel, "val"));
  o.seed = 8;
  o.out_dir = b.str();
  WriteTabletopDataset(o);  // also removes the 2-file shards left by the first run
  EXPECT_NE(SplitRecords(a.str() + rel, "train"), SplitRecords(b.str() + rel, "train"));
  EXPECT_EQ(DirBytes(b.str() + rel).size(), 8u);  // 2 JSON + 3 train + 3 val
}

TEST(TabletopWriter, RecordsReadBackWithConsistentKeysCountsAndImages) {
  ScratchDir dir;
  const TabletopOptions o = SmallOptions(dir.str());
  const TabletopSummary summary = WriteTabletopDataset(o);
  const auto info = nlohmann::json::parse(wm::ReadFile(summary.dataset_dir + "/dataset_info.json"));
  ASSERT_EQ(info["splits"].size(), 2u);
  EXPECT_EQ(info["splits"][0]["shardLengths"], nlohmann::json({"3", "3"}));
  EXPECT_EQ(info["splits"][1]["shardLengths"], nlohmann::json({"2", "1"}));
  EXPECT_EQ(info["splits"][0]["numBytes"],
            std::to_string(
                fs::file_size(summary.dataset_dir + "/wm_tabletop-train.tfrecord-00000-of-00002") +
                fs::file_size(summary.dataset_dir + "/wm_tabletop-train.tfrecord-00001-of-00002")));
  const std::vector<std::string> records = SplitRecords(summary.dataset_dir, "train");
  ASSERT_EQ(records.size(), 6u);
  for (size_t e = 0; e < records.size(); ++e) {
    wm::rlds::Example ex(records[e]);
    EXPECT_EQ(ex.Keys(), TabletopFeatureKeys());
    const size_t t = ex.Count(kIsFirstKey);
    ASSERT_GE(t, 1u);
    ASSERT_LE(t, 12u);
    for (const char* key : {kImageKey, kDepthKey, kSegmentationKey, kRewardKey, kDiscountKey,
                            kIsLastKey, kIsTerminalKey, kInstructionKey}) {
      EXPECT_EQ(ex.Count(key), t) << key;
    }
    EXPECT_EQ(ex.Count(kActionKey), 7 * t);
    EXPECT_EQ(ex.Bytes(kPolicyIdKey),
              std::vector<std::string>{PolicyName(o.PolicyForEpisode(static_cast<int>(e)))});
    EXPECT_EQ(ex.Int64s(kEpisodeSeedKey)[0], static_cast<int64_t>(EpisodeSeed(7, "train", e)));
    const CameraIntrinsics k = IntrinsicsForSize(64);
    EXPECT_EQ(ex.Floats(kIntrinsicsKey), (std::vector<float>{k.fx, k.fy, k.cx, k.cy}));
    const auto first = ex.Int64s(kIsFirstKey), last = ex.Int64s(kIsLastKey);
    EXPECT_EQ(first[0], 1);
    EXPECT_EQ(std::count(first.begin(), first.end(), 1), 1);
    EXPECT_EQ(last.back(), 1);
    EXPECT_EQ(std::count(last.begin(), last.end(), 1), 1);
    for (float g : ex.Floats(kActionKey)) EXPECT_LE(std::abs(g), 1.0f);
    const cv::Mat image = Decode(ex.Bytes(kImageKey)[t - 1]);
    const cv::Mat depth = Decode(ex.Bytes(kDepthKey)[t - 1]);
    const cv::Mat labels = Decode(ex.Bytes(kSegmentationKey)[t - 1]);
    EXPECT_EQ(image.type(), CV_8UC3);
    EXPECT_EQ(depth.type(), CV_16UC1);
    EXPECT_EQ(labels.type(), CV_8UC1);
    for (const cv::Mat& m : {image, depth, labels}) EXPECT_EQ(m.size(), cv::Size(64, 64));
    double max_label = 0, min_depth = 0;
    cv::minMaxLoc(labels, nullptr, &max_label);
    cv::minMaxLoc(depth, &min_depth);
    EXPECT_LE(max_label, 3);
    EXPECT_GT(min_depth, 100);  // everything is at least 10 cm from the camera
  }
}

TEST(TabletopRender, RobotLabelMarksExactlyThePixelsTheRobotChanges) {
  const Scene scene = FixedScene();
  const Frame with = RenderFrame(scene, 128);
  const Frame without = RenderFrame(scene, 128, {.draw_robot = false});
  EXPECT_EQ(CountLabel(without, kLabelRobot), 0);
  EXPECT_GT(CountLabel(with, kLabelRobot), 300);
  EXPECT_GT(CountLabel(with, kLabelBlock), 20);
  EXPECT_GT(CountLabel(with, kLabelGoal), 100);
  for (size_t i = 0; i < with.labels.size(); ++i) {
    if (with.labels[i] == kLabelRobot) {
      ASSERT_LT(with.depth_mm[i], without.depth_mm[i]) << "pixel " << i;  // robot in front
    } else {
      ASSERT_EQ(with.depth_mm[i], without.depth_mm[i]) << "pixel " << i;
      ASSERT_EQ(with.labels[i], without.labels[i]) << "pixel " << i;
    }
  }
}

TEST(TabletopRender, DepthBackProjectsOntoTheTablePlane) {
  const Frame f = RenderFrame(FixedScene(), 96);
  const CameraIntrinsics k = IntrinsicsForSize(96);
  const CameraPose cam = TableCamera();
  int checked = 0;
  for (int v = 0; v < 96; v += 5) {
    for (int u = 0; u < 96; u += 5) {
      const size_t i = static_cast<size_t>(v) * 96 + u;
      if (f.labels[i] != kLabelTable && f.labels[i] != kLabelGoal) continue;
      const double z = f.depth_mm[i] / 1000.0;
      const Vec3 p = cam.position + cam.right * ((u - k.cx) * z / k.fx) +
                     cam.down * ((v - k.cy) * z / k.fy) + cam.forward * z;
      ASSERT_NEAR(p.z, 0.0, 0.002) << "u " << u << " v " << v;  // 1 mm depth quantization
      ++checked;
    }
  }
  EXPECT_GT(checked, 200);
}

TEST(TabletopRender, RaisingTheGripperShrinksItsAreaAndYawRotatesIt) {
  // Raising pulls the gripper towards the top of the image, so less of the arm link is in view
  // (the gripper itself grows slightly as it nears the camera).
  Scene scene = FixedScene();
  const Frame low = RenderFrame(scene, 128);
  for (int i = 0; i < 3; ++i) StepScene(scene.state, {0, 0, 0.04f, 0, 0, 0, 0});
  EXPECT_NEAR(scene.state.ee.z, 0.2, 1e-6);
  const Frame high = RenderFrame(scene, 128);
  EXPECT_LT(CountLabel(high, kLabelRobot), CountLabel(low, kLabelRobot) * 0.9);
  StepScene(scene.state, {0, 0, 0, 0, 0, 0.25f, 0});
  const Frame turned = RenderFrame(scene, 128);
  int changed = 0;
  for (size_t i = 0; i < high.labels.size(); ++i) {
    changed += (high.labels[i] == kLabelRobot) != (turned.labels[i] == kLabelRobot);
  }
  EXPECT_GT(changed, 20);
  StepScene(scene.state, {0, 0, 0, 0, 0, 0, 1});  // closing moves the fingers
  const Frame closed = RenderFrame(scene, 128);
  EXPECT_NE(closed.labels, turned.labels);
}

TEST(TabletopEpisode, RewardIsOneExactlyOnTheTerminalStep) {
  for (PolicyKind kind : {PolicyKind::kExpert, PolicyKind::kNoisy, PolicyKind::kRandom}) {
    for (int e = 0; e < 10; ++e) {
      const Rollout r = RollOut(EpisodeSeed(1, "train", e), kind, 40);
      ASSERT_FALSE(r.steps.empty());
      for (size_t t = 0; t + 1 < r.steps.size(); ++t) {
        EXPECT_EQ(r.steps[t].reward, 0.0f);
        EXPECT_FALSE(r.steps[t].is_last || r.steps[t].is_terminal);
        EXPECT_FALSE(BlockInGoal(r.steps[t].state));
      }
      const EpisodeStep& last = r.steps.back();
      EXPECT_TRUE(last.is_last);
      EXPECT_EQ(last.is_terminal, r.success);
      EXPECT_EQ(last.reward, r.success ? 1.0f : 0.0f);
      EXPECT_EQ(BlockInGoal(last.state), r.success);
      if (!r.success) {
        EXPECT_EQ(r.steps.size(), 40u);
      }
    }
  }
}

TEST(TabletopEpisode, ExpertSucceedsFarMoreOftenThanRandomOrWrongGoal) {
  auto successes = [](PolicyKind kind) {
    int n = 0;
    for (int e = 0; e < 20; ++e) n += RollOut(EpisodeSeed(2, "val", e), kind, 40).success;
    return n;
  };
  const int expert = successes(PolicyKind::kExpert);
  const int noisy = successes(PolicyKind::kNoisy);
  EXPECT_GE(expert, 17);
  EXPECT_LE(successes(PolicyKind::kRandom), 3);
  EXPECT_LE(successes(PolicyKind::kWrongGoal), 3);
  EXPECT_LT(noisy, expert);
  EXPECT_GE(noisy, 4);
}

TEST(TabletopEpisode, SeedsAreStableAndIndependent) {
  EXPECT_NE(EpisodeSeed(0, "train", 0), EpisodeSeed(0, "val", 0));
  EXPECT_NE(EpisodeSeed(0, "train", 0), EpisodeSeed(1, "train", 0));
  EXPECT_LT(EpisodeSeed(0, "train", 5), uint64_t{1} << 63);
  Rng a(42), b(42);
  double sum = 0, sum_sq = 0;
  for (int i = 0; i < 20000; ++i) {
    const double x = a.Normal();
    EXPECT_EQ(x, b.Normal());
    sum += x, sum_sq += x * x;
  }
  EXPECT_NEAR(sum / 20000, 0.0, 0.03);
  EXPECT_NEAR(sum_sq / 20000, 1.0, 0.05);
  // The engine's sequence is fixed by the standard (10000th output of the default seed).
  std::mt19937_64 engine;
  engine.discard(9999);
  EXPECT_EQ(engine(), 9981545732273789042ULL);
}

TEST(TabletopOptions, CheckRejectsBadValuesNamingTheFlag) {
  TabletopOptions o = SmallOptions("/tmp/unused");
  o.size = 300;
  try {
    o.Check();
    FAIL() << "size 300 accepted";
  } catch (const wm::Error& e) {
    EXPECT_EQ(e.context().key, "--size");
    EXPECT_NE(std::string(e.what()).find("64..256"), std::string::npos);
  }
  o.size = 64;
  o.policies = {"expert", "psychic"};
  EXPECT_THROW(o.Check(), wm::Error);
  o.policies = {"random"};
  o.version = "1.0";
  EXPECT_THROW(o.Check(), wm::Error);
  o.version = "2.1.0";
  EXPECT_NO_THROW(o.Check());
}

TEST(TabletopOptions, GoalRegionIsParsedAndCheckedNamingTheFlag) {
  const GoalRegion r = ParseGoalRegion("-0.2,0,0.05,0.3");
  EXPECT_EQ(r, (GoalRegion{-0.2, 0, 0.05, 0.3}));
  for (const char* bad : {"", "0.1,0.2,0.3", "0.1,0.2,0.3,0.4,0.5", "a,0.2,0,0.3", "0.1,,0,0.3",
                          "0.2,0.1,0,0.3", "0,0.2,0.3,0.3", "0,0.2,0,0.3x"}) {
    try {
      ParseGoalRegion(bad);
      FAIL() << "'" << bad << "' accepted";
    } catch (const wm::Error& e) {
      EXPECT_EQ(e.context().key, "--goal-region") << bad;
      EXPECT_NE(std::string(e.what()).find("XMIN,XMAX,YMIN,YMAX"), std::string::npos) << bad;
    }
  }
  TabletopOptions o = SmallOptions("/tmp/unused");
  for (const GoalRegion& bad : {GoalRegion{0.1, 0.3, 0, 0.3}, GoalRegion{-0.2, 0.2, -0.2, 0.3},
                                GoalRegion{0.1, 0.15, 0, 0.3}, GoalRegion{0, 0.2, 0, 0.05}}) {
    o.goal_region = bad;
    try {
      o.Check();
      FAIL() << "region x [" << bad.x_min << ", " << bad.x_max << "] accepted";
    } catch (const wm::Error& e) {
      EXPECT_EQ(e.context().key, "--goal-region");
    }
  }
  o.goal_region = kGoalRegionBounds;
  EXPECT_NO_THROW(o.Check());
}

TEST(TabletopEpisode, GoalRegionHoldsEveryGoalAndTheDefaultDrawsAsBefore) {
  // Goals of the default region, pinned from the generator before regions existed: datasets
  // made without --goal-region keep their bytes.
  for (const auto& [seed, x, y] : {std::tuple{7, 0.19810473071146578, 0.34746109128511193},
                                   std::tuple{8, -0.0065968459592183337, 0.31957301567291929}}) {
    Rng rng(seed);
    const Scene scene = SampleScene(rng);
    EXPECT_NEAR(scene.state.goal.x, x, 1e-12) << "seed " << seed;
    EXPECT_NEAR(scene.state.goal.y, y, 1e-12) << "seed " << seed;
  }
  // One side of the table: every goal inside, 15-30 cm from the block as always. A region in
  // the middle leaves some blocks no such goal: they get its farthest corner, never a block
  // that starts in the goal.
  const GoalRegion right = {0.05, 0.2, -0.05, 0.35}, middle = {-0.05, 0.05, 0.1, 0.2};
  int corners = 0;
  for (int e = 0; e < 300; ++e) {
    Rng a(EpisodeSeed(5, "train", e)), b(EpisodeSeed(5, "train", e));
    const SceneState s = SampleScene(a, LookVariation::kVaried, right).state;
    EXPECT_TRUE(right.Contains(s.goal)) << "episode " << e;
    const double d = HorizontalDistance(s.goal, s.block);
    EXPECT_TRUE(d >= 0.15 && d <= 0.3) << "episode " << e << ": " << d;
    const SceneState m = SampleScene(b, LookVariation::kVaried, middle).state;
    EXPECT_TRUE(middle.Contains(m.goal)) << "episode " << e;
    EXPECT_FALSE(BlockInGoal(m)) << "episode " << e;
    corners += (m.goal.x == middle.x_min || m.goal.x == middle.x_max) &&
               (m.goal.y == middle.y_min || m.goal.y == middle.y_max);
  }
  EXPECT_GT(corners, 0);  // the fallback was exercised
  const Rollout expert =
      RollOut(EpisodeSeed(5, "val", 0), PolicyKind::kExpert, 40, LookVariation::kPlain, right);
  EXPECT_TRUE(right.Contains(expert.steps.front().state.goal));
  EXPECT_TRUE(expert.success);
}

TEST(TabletopRender, ScreenBoundsCullingNeverChangesAPixel) {
  Rng rng(11);
  for (int trial = 0; trial < 12; ++trial) {
    Scene scene = SampleScene(rng);
    // Include the workspace corners (near edge, tilted wrist, top) where culling is tightest.
    scene.state.ee = {rng.Uniform(kEeMin.x, kEeMax.x),
                      trial < 4 ? kEeMin.y : rng.Uniform(-0.1, 0.4),
                      trial % 2 ? kEeMax.z : rng.Uniform(kEeMin.z, kEeMax.z)};
    scene.state.ee_rpy = {rng.Uniform(-kMaxTilt, kMaxTilt), rng.Uniform(-kMaxTilt, kMaxTilt),
                          rng.Uniform(-3, 3)};
    const Frame fast = RenderFrame(scene, 64);
    const Frame reference = RenderFrame(scene, 64, {.cull = false});
    EXPECT_EQ(fast.rgb, reference.rgb) << "trial " << trial;
    EXPECT_EQ(fast.depth_mm, reference.depth_mm) << "trial " << trial;
    EXPECT_EQ(fast.labels, reference.labels) << "trial " << trial;
  }
}

namespace {

// The share of table pixels that have the table's most common colour.
double ModalTableShare(const Frame& f) {
  std::map<std::array<uint8_t, 3>, int> counts;
  int table = 0;
  for (size_t p = 0; p < f.labels.size(); ++p) {
    if (f.labels[p] != kLabelTable) continue;
    ++counts[{f.rgb[3 * p], f.rgb[3 * p + 1], f.rgb[3 * p + 2]}];
    ++table;
  }
  int modal = 0;
  for (const auto& [colour, n] : counts) modal = std::max(modal, n);
  return static_cast<double>(modal) / table;
}

}  // namespace

TEST(TabletopEpisode, PlainLookKeepsTheEpisodeAndDropsTheTexture) {
  const Rollout first =
      RollOut(EpisodeSeed(4, "train", 0), PolicyKind::kNoisy, 1, LookVariation::kPlain);
  for (int e = 0; e < 6; ++e) {
    const uint64_t seed = EpisodeSeed(4, "train", e);
    const Rollout varied = RollOut(seed, PolicyKind::kNoisy, 30);
    const Rollout plain = RollOut(seed, PolicyKind::kNoisy, 30, LookVariation::kPlain);
    ASSERT_EQ(plain.steps.size(), varied.steps.size()) << "episode " << e;
    for (size_t t = 0; t < plain.steps.size(); ++t) {
      EXPECT_EQ(plain.steps[t].action, varied.steps[t].action) << "episode " << e << " step " << t;
      EXPECT_EQ(plain.steps[t].state.ee.x, varied.steps[t].state.ee.x);
      EXPECT_EQ(plain.steps[t].state.block.y, varied.steps[t].state.block.y);
    }
    EXPECT_EQ(plain.look.instruction, varied.look.instruction);
    // Every plain episode has the same table and light; the varied ones differ.
    EXPECT_EQ(plain.look.table_rgb.x, first.look.table_rgb.x);
    EXPECT_EQ(plain.look.light_dir.z, first.look.light_dir.z);
    // Untextured: one colour covers the table but for shadows (measured 0.93-0.98); a texture
    // splits it (a checker board in two, measured <= 0.49).
    const Frame plain_frame = RenderFrame({plain.steps[0].state, plain.look}, 64);
    const Frame varied_frame = RenderFrame({varied.steps[0].state, varied.look}, 64);
    EXPECT_GT(ModalTableShare(plain_frame), 0.9) << "episode " << e;
    EXPECT_LT(ModalTableShare(varied_frame), 0.7) << "episode " << e;
  }
}

// RLDS reading against a dataset written outside wmkit (tests/data/rlds, OXE fractal layout).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <utility>

#include "core/atomic_file.h"
#include "core/error.h"
#include "ingest/rlds/dataset_mapping.h"
#include "ingest/rlds/example.h"
#include "ingest/rlds/rlds_source.h"
#include "ingest/rlds/tfrecord.h"
#include "tests/core/test_util.h"

namespace wm::ingest {
namespace {
namespace fs = std::filesystem;

using test::SourceDir;
std::string FractalDir() { return SourceDir() + "/tests/data/rlds/fractal20220817_data/0.1.0"; }
std::string ConfigsDir() { return SourceDir() + "/configs"; }

nlohmann::json Expected() {
  return nlohmann::json::parse(
      ReadFile(SourceDir() + "/tests/data/rlds/fractal20220817_data.expected.json"));
}

using test::ErrorText;

TEST(TfRecord, ReadsExternallyWrittenFilesWithValidCrcs) {
  // dataset_info.json says shardLengths 3 and 2.
  rlds::TfRecordReader a(FractalDir() + "/fractal20220817_data-train.tfrecord-00000-of-00002");
  rlds::TfRecordReader b(FractalDir() + "/fractal20220817_data-train.tfrecord-00001-of-00002");
  EXPECT_EQ(a.num_records(), 3u);
  EXPECT_EQ(b.num_records(), 2u);
  for (size_t k = 0; k < 3; ++k) EXPECT_GT(a.Record(k).size(), 1000u);  // data CRCs checked
}

TEST(TfRecord, WriterRoundTripsAndCorruptionNamesFileAndRecord) {
  test::TempDir dir;
  std::string path = dir / "x.tfrecord";
  rlds::TfRecordWriter w(path);
  for (const std::string& r : {std::string("alpha"), std::string(), std::string(3000, 'z')}) {
    w.Write(r);
  }
  w.Close();
  rlds::TfRecordReader r(path);
  ASSERT_EQ(r.num_records(), 3u);
  EXPECT_EQ(r.Record(0), "alpha");
  EXPECT_EQ(r.Record(1), "");
  EXPECT_EQ(rlds::ReadTfRecordAt(path, r.record_offsets()[2]), std::string(3000, 'z'));

  test::FlipByte(path, r.record_offsets()[2] + 12 + 100);  // payload of record 2
  rlds::TfRecordReader flipped(path);
  std::string msg = ErrorText([&] { flipped.Record(2); });
  EXPECT_NE(msg.find("record 2"), std::string::npos) << msg;
  EXPECT_NE(msg.find("data CRC mismatch"), std::string::npos) << msg;
  EXPECT_NE(msg.find(path), std::string::npos) << msg;

  test::FlipByte(path, r.record_offsets()[1] + 3);  // length field of record 1
  msg = ErrorText([&] { rlds::TfRecordReader again(path); });
  EXPECT_NE(msg.find("record 1"), std::string::npos) << msg;
  EXPECT_NE(msg.find("length CRC"), std::string::npos) << msg;
  EXPECT_EQ(rlds::ScanTfRecordOffsets(path, /*stop_at_damage=*/true).size(), 1u);

  test::Truncate(path, r.record_offsets()[2] + 20);
  test::FlipByte(path, r.record_offsets()[1] + 3);  // repair record 1
  msg = ErrorText([&] { rlds::TfRecordReader again(path); });
  EXPECT_NE(msg.find("truncated"), std::string::npos) << msg;
}

TEST(Example, TypedAccessAndErrorsNameTheKey) {
  rlds::ExampleBuilder b;
  b.AddFloats("steps/reward", {0.f, 1.f});
  b.AddBytes("steps/language", {"hi", "hi"});
  b.AddInt64s("steps/is_first", {1, 0});
  rlds::Example ex(b.Serialize());
  EXPECT_EQ(ex.Floats("steps/reward"), (std::vector<float>{0.f, 1.f}));
  EXPECT_EQ(ex.Int64s("steps/is_first"), (std::vector<int64_t>{1, 0}));
  EXPECT_EQ(ex.Keys().size(), 3u);
  std::string msg = ErrorText([&] { ex.Floats("steps/language"); });
  EXPECT_NE(msg.find("key 'steps/language'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("float"), std::string::npos) << msg;
  msg = ErrorText([&] { ex.Bytes("steps/missing"); });
  EXPECT_NE(msg.find("missing"), std::string::npos) << msg;
  EXPECT_THROW(rlds::Example("\xff\xff\xff garbage"), Error);
  EXPECT_EQ(b.Serialize(), b.Serialize());  // deterministic
}

TEST(RldsSource, FeatureSpecFromFeaturesJson) {
  rlds::TfdsDataset d = rlds::OpenTfdsDataset(FractalDir());
  EXPECT_EQ(d.name, "fractal20220817_data");
  const auto& image = d.features.at("steps/observation/image");
  EXPECT_EQ(image.tfds_class, "Image");
  EXPECT_EQ(image.shape, (std::vector<int64_t>{256, 320, 3}));
  EXPECT_EQ(image.encoding, "jpeg");
  EXPECT_TRUE(image.per_step);
  EXPECT_EQ(d.features.at("steps/action/world_vector").ElementSize(), 3);
  EXPECT_EQ(d.SplitFiles("train").size(), 2u);
  EXPECT_THROW(d.SplitFiles("val"), Error);
  // The dataset directory (holding version directories) resolves to the newest version.
  EXPECT_EQ(rlds::OpenTfdsDataset(fs::path(FractalDir()).parent_path()).version, "0.1.0");
}

// Every episode of the external sample is recovered exactly as its expected.json says.
TEST(RldsSource, RecoversEveryFractalEpisodeExactly) {
  RldsSource source(FractalDir(), "train", "", ConfigsDir());
  std::vector<EpisodeRef> refs = source.ListEpisodes(nullptr);
  nlohmann::json expected = Expected();
  ASSERT_EQ(refs.size(), expected.size());
  for (size_t i = 0; i < refs.size(); ++i) {
    Episode e = source.Load(refs[i]);
    const auto& x = expected[i];
    ASSERT_EQ(e.num_steps, x["num_steps"].get<int64_t>()) << i;
    for (int64_t t = 0; t < e.num_steps; ++t) {
      for (int d = 0; d < kActionDim; ++d) {
        EXPECT_EQ(e.actions[t * kActionDim + d], x["actions"][t][d].get<float>()) << i << " " << t;
      }
      EXPECT_EQ(e.rewards[t], x["rewards"][t].get<float>());
    }
    EXPECT_EQ(e.language_instruction, x["language_instruction"].get<std::string>());
    EXPECT_EQ(e.is_first.front(), 1);
    EXPECT_EQ(e.is_last.back(), 1);
    EXPECT_EQ(e.images.at("image").frames.size(), static_cast<size_t>(e.num_steps));
    EXPECT_EQ(e.episode_key, refs[i].rel_path + "#" + std::to_string(refs[i].record));
  }
}

// A mapping with another action space keeps the parts' width: fractal's world vector and gripper
// (4 values) as an `other` action, each value the one the canonical mapping puts at its place.
TEST(RldsSource, AnotherActionSpaceKeepsThePartsWidth) {
  test::TempDir dir;
  std::string mapping = dir / "arm_and_gripper.yaml";
  WriteFileAtomically(mapping,
                      "dataset: fractal20220817_data\nimage: steps/observation/image\n"
                      "action_space: other\naction:\n  - key: steps/action/world_vector\n"
                      "  - key: steps/action/gripper_closedness_action\n");
  RldsSource narrow(FractalDir(), "train", mapping, ConfigsDir());
  RldsSource canonical(FractalDir(), "train", "", ConfigsDir());
  const std::vector<EpisodeRef> refs = canonical.ListEpisodes(nullptr);
  ASSERT_FALSE(refs.empty());
  const Episode e = narrow.Load(refs[0]), c = canonical.Load(refs[0]);
  EXPECT_EQ((std::pair{e.action_dim, e.action_space}),
            (std::pair<int64_t, std::string>{4, "other"}));
  ASSERT_EQ(e.actions.size(), static_cast<size_t>(4 * e.num_steps));
  for (int64_t t = 0; t < e.num_steps; ++t) {
    for (int d : {0, 1, 2}) EXPECT_EQ(e.actions[t * 4 + d], c.actions[t * kActionDim + d]);
    EXPECT_EQ(e.actions[t * 4 + 3], c.actions[t * kActionDim + 6]);  // the gripper
  }
  EXPECT_EQ(c.action_space, "eef_delta");
  // The canonical mapping's record (and so the config hash) has no action_space.
  EXPECT_FALSE(rlds::LoadDatasetMapping(ConfigsDir() + "/datasets/fractal20220817_data.yaml")
                   .ToJson()
                   .contains("action_space"));
  EXPECT_EQ(rlds::LoadDatasetMapping(mapping).ToJson()["action_space"], "other");

  WriteFileAtomically(mapping,
                      "dataset: x\nimage: steps/observation/image\naction_space: joints\n"
                      "action:\n  - key: steps/action/world_vector\n");
  const std::string msg =
      ErrorText([&] { RldsSource s(FractalDir(), "train", mapping, ConfigsDir()); });
  for (const char* part : {"arm_and_gripper.yaml", "key 'action_space'", "got 'joints'"}) {
    EXPECT_NE(msg.find(part), std::string::npos) << msg;
  }
}

TEST(RldsSource, MappingErrorsAreClear) {
  test::TempDir dir;
  std::string mapping = dir / "bad.yaml";
  WriteFileAtomically(mapping,
                      "dataset: fractal20220817_data\nimage: steps/observation/image\n"
                      "action:\n  - key: steps/action/world_vector\n");
  std::string msg = ErrorText([&] { RldsSource s(FractalDir(), "train", mapping, ConfigsDir()); });
  EXPECT_NE(msg.find("expected 7"), std::string::npos) << msg;
  EXPECT_NE(msg.find("bad.yaml"), std::string::npos) << msg;

  WriteFileAtomically(mapping, "dataset: x\nimage: steps/observation/nope\naction: []\n");
  msg = ErrorText([&] { RldsSource s(FractalDir(), "train", mapping, ConfigsDir()); });
  EXPECT_NE(msg.find("steps/observation/nope"), std::string::npos) << msg;

  WriteFileAtomically(mapping,
                      "dataset: x\nimage: steps/observation/image\naction:\n"
                      "  - {key: steps/action/world_vector, select: [0, 1, 5]}\n"
                      "  - {zeros: 4}\n");
  msg = ErrorText([&] { RldsSource s(FractalDir(), "train", mapping, ConfigsDir()); });
  EXPECT_NE(msg.find("select index 5 is outside"), std::string::npos) << msg;

  // A misspelt key must not fall back to a default (here: no language instructions).
  WriteFileAtomically(mapping,
                      "dataset: x\nimage: steps/observation/image\naction: []\n"
                      "language_instuction: steps/language_instruction\n");
  msg = ErrorText([&] { RldsSource s(FractalDir(), "train", mapping, ConfigsDir()); });
  EXPECT_NE(msg.find("key 'language_instuction'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("unknown key"), std::string::npos) << msg;
  WriteFileAtomically(mapping,
                      "dataset: x\nimage: steps/observation/image\naction:\n"
                      "  - {key: steps/action/world_vector, scal: 2}\n");
  msg = ErrorText([&] { RldsSource s(FractalDir(), "train", mapping, ConfigsDir()); });
  EXPECT_NE(msg.find("key 'action[0].scal'"), std::string::npos) << msg;

  msg = ErrorText([&] { RldsSource s(FractalDir(), "train", "", dir.path().string()); });
  EXPECT_NE(msg.find("no dataset mapping for 'fractal20220817_data'"), std::string::npos) << msg;
}

TEST(RldsSource, WrongValueCountNamesRecordAndKey) {
  RldsSource source(FractalDir(), "train", "", ConfigsDir());
  // An example whose world_vector has one value too few for its 2 steps.
  rlds::ExampleBuilder b;
  b.AddBytes("steps/observation/image", {"a", "b"});
  b.AddFloats("steps/action/world_vector", {0, 0, 0, 0, 0});
  std::string msg = ErrorText([&] { source.MapExample(b.Serialize()); });
  EXPECT_NE(msg.find("steps/action/world_vector"), std::string::npos) << msg;
  EXPECT_NE(msg.find("expected 2 steps x 3"), std::string::npos) << msg;
}

}  // namespace
}  // namespace wm::ingest

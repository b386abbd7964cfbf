// Errors, atomic files, hashes, provenance, progress formatting, zstd and strict JSON integers.
#include <gtest/gtest.h>

#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/json_int.h"
#include "core/progress.h"
#include "core/provenance.h"
#include "core/sha256.h"
#include "core/zstd_codec.h"
#include "tests/core/test_util.h"

namespace wm {
namespace {

TEST(Error, NamesFileRecordAndKey) {
  Error e = Error("expected 7 values").WithKey("steps/action").WithRecord(3).WithFile("a.tfrecord");
  EXPECT_STREQ(e.what(), "a.tfrecord: record 3: key 'steps/action': expected 7 values");
  // Inner context wins: the first file named is the most specific one.
  EXPECT_EQ(e.WithFile("outer").context().file, "a.tfrecord");
}

TEST(Sha256, KnownVectors) {
  EXPECT_EQ(Sha256Hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(AtomicFile, CommitReplacesAndFailureLeavesOldContent) {
  test::TempDir dir;
  std::string path = dir / "f.txt";
  WriteFileAtomically(path, "old");
  {
    AtomicFileWriter w(path);
    w.Write("new but abandoned");
  }
  EXPECT_EQ(ReadFile(path), "old");
  EXPECT_FALSE(std::filesystem::exists(TempPathFor(path)));
  WriteFileAtomically(path, "new");
  EXPECT_EQ(ReadFile(path), "new");
}

TEST(AtomicFile, UnwritableDirectoryIsAClearError) {
  try {
    WriteFileAtomically("/nonexistent-dir/x/y.json", "data");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-dir/x/"), std::string::npos) << e.what();
  }
}

TEST(Zstd, RoundTripAndCorruption) {
  std::string raw(10000, 'x');
  for (size_t i = 0; i < raw.size(); i += 7) raw[i] = static_cast<char>(i);
  std::string packed = ZstdCompress(raw);
  EXPECT_LT(packed.size(), raw.size());
  EXPECT_EQ(ZstdDecompress(packed, raw.size()), raw);
  EXPECT_THROW(ZstdDecompress(packed, raw.size() + 1), Error);
  packed[packed.size() / 2] ^= 0x55;
  EXPECT_THROW(ZstdDecompress(packed.substr(0, packed.size() / 2), raw.size()), Error);
  // A damaged raw_length of 1 PB is an error about the size, not an allocation of 1 PB.
  EXPECT_NE(test::ErrorText([&] {
              ZstdDecompress(ZstdCompress(raw), uint64_t{1} << 50);
            }).find("decompressed to 10000 bytes"),
            std::string::npos);
}

TEST(JsonInt, AcceptsOnlyIntegersInRange) {
  using nlohmann::json;
  EXPECT_EQ(JsonInt<uint32_t>(json(4294967295u)), 4294967295u);
  EXPECT_EQ(JsonInt<int>(json(-3)), -3);
  for (const json& bad : {json(1.44e120), json(3.5), json(-1), json(true), json("7")}) {
    EXPECT_THROW(JsonInt<uint32_t>(bad), json::type_error) << bad.dump();
  }
  EXPECT_THROW(JsonInt<int>(json(int64_t{1} << 40)), json::type_error);
  EXPECT_EQ(JsonInts<int64_t>(json::parse("[2, -1]")), (std::vector<int64_t>{2, -1}));
  EXPECT_THROW(JsonInts<int64_t>(json::parse("[2, 0.5]")), json::type_error);
}

TEST(Provenance, ConfigHashIgnoresKeyOrderButNotValues) {
  nlohmann::json a = {{"x", 1}, {"y", "z"}}, b = {{"y", "z"}, {"x", 1}}, c = {{"x", 2}, {"y", "z"}};
  EXPECT_EQ(ConfigHash(a), ConfigHash(b));
  EXPECT_NE(ConfigHash(a), ConfigHash(c));
  nlohmann::json p = MakeProvenance("t", a);
  for (const char* key : {"tool", "wmkit_version", "git_commit", "config_hash", "libraries"}) {
    EXPECT_TRUE(p.contains(key)) << key;
  }
  EXPECT_TRUE(p["libraries"].contains("zstd"));
}

TEST(Provenance, ResumeConfigCheckNamesWhatChanged) {
  const nlohmann::json stored = {{"model", {{"d", 8}, {"norm", "layer"}}},
                                 {"train", {{"steps", 2}}}};
  EXPECT_NO_THROW(CheckResumeConfig("", stored, stored));
  nlohmann::json current = stored;
  current["train"]["steps"] = 6;
  // The recorded hash wins: a config written before a key existed still resumes.
  EXPECT_NO_THROW(CheckResumeConfig(ConfigHash(current), stored, current));
  const std::string one = test::ErrorText([&] { CheckResumeConfig("", stored, current); });
  EXPECT_NE(one.find("different config (train.steps: 2 -> 6); --resume"), std::string::npos) << one;
  current["model"]["norm"] = "rms";
  current["model"].erase("d");
  current["model"]["extra"] = true;
  const std::string three = test::ErrorText([&] { CheckResumeConfig("", stored, current); });
  for (const char* change : {"model.d: 8 -> (none)", "model.extra: (none) -> true",
                             "model.norm: \"layer\" -> \"rms\"", "train.steps: 2 -> 6"}) {
    EXPECT_NE(three.find(change), std::string::npos) << change << " in " << three;
  }
  for (int i = 0; i < 4; ++i) current["train"]["k" + std::to_string(i)] = i;
  const std::string many = test::ErrorText([&] { CheckResumeConfig("", stored, current); });
  EXPECT_NE(many.find(" and 3 more);"), std::string::npos) << many;
}

TEST(Progress, LineShowsRateAndEta) {
  std::string line = Progress::FormatLine("ingest", 25, 100, "episodes", 5.0, 10);
  EXPECT_NE(line.find(" 25%"), std::string::npos) << line;
  EXPECT_NE(line.find("5.0 episodes/s"), std::string::npos) << line;
  EXPECT_NE(line.find("ETA 00:15"), std::string::npos) << line;
  EXPECT_NE(line.find("|##        |"), std::string::npos) << line;
  EXPECT_EQ(Progress::FormatDuration(3725), "1:02:05");
}

}  // namespace
}  // namespace wm

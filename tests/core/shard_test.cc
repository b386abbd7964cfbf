// Shard file round trip and every corruption class the format must detect.
#include <gtest/gtest.h>

#include <filesystem>

#include "core/atomic_file.h"
#include "core/crc32c.h"
#include "core/error.h"
#include "core/shard/shard_reader.h"
#include "core/shard/shard_writer.h"
#include "tests/core/test_util.h"

namespace wm::shard {
namespace {
namespace fs = std::filesystem;
using test::MakeEpisode;

void ExpectSameEpisode(const Episode& a, const Episode& b) {
  EXPECT_EQ(a.episode_key, b.episode_key);
  EXPECT_EQ(a.num_steps, b.num_steps);
  EXPECT_EQ(a.actions, b.actions);
  EXPECT_EQ(a.rewards, b.rewards);
  EXPECT_EQ(a.discounts, b.discounts);
  EXPECT_EQ(a.is_first, b.is_first);
  EXPECT_EQ(a.is_last, b.is_last);
  EXPECT_EQ(a.is_terminal, b.is_terminal);
  EXPECT_EQ(a.language_instruction, b.language_instruction);
  EXPECT_EQ(a.policy_id, b.policy_id);
  EXPECT_EQ(a.episode_seed, b.episode_seed);
  ASSERT_EQ(a.images.size(), b.images.size());
  EXPECT_EQ(a.images.at("image").frames, b.images.at("image").frames);
  EXPECT_EQ(a.images.at("image").height, b.images.at("image").height);
}

class ShardTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = dir_ / "shard-00000.wms";
    ShardWriter w(path_);
    for (int i = 0; i < 3; ++i) {
      episodes_.push_back(MakeEpisode(5 + i, 100 + i, "ep" + std::to_string(i)));
      w.Append(episodes_.back());
    }
    w.Finish();
  }
  // Expects opening + reading every episode to fail with a message containing `what`.
  void ExpectCorrupt(const std::string& what) {
    try {
      ShardReader r(path_);
      for (size_t k = 0; k < r.num_episodes(); ++k) r.ReadEpisode(k);
      FAIL() << "corruption not detected, expected: " << what;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(path_), std::string::npos) << e.what();
    }
  }
  test::TempDir dir_;
  std::string path_;
  std::vector<Episode> episodes_;
};

TEST_F(ShardTest, RoundTripsEveryEpisode) {
  ShardReader r(path_);
  ASSERT_EQ(r.num_episodes(), 3u);
  for (size_t k = 0; k < 3; ++k) {
    ExpectSameEpisode(r.ReadEpisode(k), episodes_[k]);
    EXPECT_EQ(r.entries()[k].num_steps, static_cast<uint32_t>(episodes_[k].num_steps));
  }
  EXPECT_FALSE(fs::exists(TempPathFor(path_))) << "temp file left behind";
}

TEST_F(ShardTest, RandomAccessReadsOnlyTheRequestedRecord) {
  ShardReader r(path_);
  // Corrupting record 0 must not affect reading record 2 (O(1) access via the footer).
  test::FlipByte(path_, r.entries()[0].offset + 30);
  ShardReader again(path_);
  ExpectSameEpisode(again.ReadEpisode(2), episodes_[2]);
  EXPECT_THROW(again.ReadEpisode(0), Error);
}

TEST_F(ShardTest, DetectsFlippedHeaderByte) {
  test::FlipByte(path_, 2);
  ExpectCorrupt("file header");
}

TEST_F(ShardTest, DetectsFlippedPayloadByte) {
  uint64_t offset = ShardReader(path_).entries()[1].offset + kRecordHeaderSize + 5;
  test::FlipByte(path_, offset);
  ExpectCorrupt("record 1");
}

TEST_F(ShardTest, DetectsFlippedLastBodyByte) {
  const IndexEntry e = ShardReader(path_).entries()[2];
  test::FlipByte(path_, e.offset + e.length - 1);
  ExpectCorrupt("CRC mismatch");
}

TEST_F(ShardTest, DetectsFlippedFooterIndexByte) {
  uint64_t size = fs::file_size(path_);
  test::FlipByte(path_, size - kTrailerSize - 3);
  ExpectCorrupt("footer index");
}

TEST_F(ShardTest, DetectsFlippedTrailerByte) {
  test::FlipByte(path_, fs::file_size(path_) - 35);
  ExpectCorrupt("trailer");
}

TEST_F(ShardTest, DetectsTruncation) {
  for (uint64_t cut : {uint64_t{1}, uint64_t{41}, uint64_t{200}}) {
    SetUp();
    test::Truncate(path_, fs::file_size(path_) - cut);
    ExpectCorrupt("trailer");
  }
  test::Truncate(path_, 10);
  ExpectCorrupt("truncated");
}

TEST_F(ShardTest, RejectsUnknownVersionClearly) {
  // Rewrite the version in header and trailer with valid CRCs: only the version is wrong.
  std::string bytes = ReadFile(path_);
  bytes[8] = 2;
  std::string head = bytes.substr(0, 12);
  uint32_t crc = Crc32c(head);
  for (int i = 0; i < 4; ++i) bytes[12 + i] = static_cast<char>((crc >> (8 * i)) & 0xff);
  WriteFileAtomically(path_, bytes);
  ExpectCorrupt("unknown shard format version 2");
}

TEST(ShardWriter, UnfinishedShardIsNeverVisible) {
  test::TempDir dir;
  std::string path = dir / "shard-00000.wms";
  {
    ShardWriter w(path);
    w.Append(MakeEpisode(3, 1));
    EXPECT_FALSE(fs::exists(path));  // only the hidden temp file exists until Finish
  }                                  // destroyed without Finish, as on a crash or exception
  EXPECT_FALSE(fs::exists(path));
  EXPECT_FALSE(fs::exists(TempPathFor(path)));
}

TEST(ShardWriter, SameEpisodesGiveIdenticalBytes) {
  test::TempDir dir;
  for (const char* name : {"a.wms", "b.wms"}) {
    ShardWriter w(dir / name);
    w.Append(MakeEpisode(7, 42));
    w.Finish();
  }
  EXPECT_EQ(ReadFile(dir / "a.wms"), ReadFile(dir / "b.wms"));
}

}  // namespace
}  // namespace wm::shard

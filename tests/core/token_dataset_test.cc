// Token datasets: write parts, assemble index.json, read back through the memory map, and
// refuse corrupt, truncated or mixed-up files with an error naming the file and section.
#include "core/tokens/token_dataset.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"
#include "tests/core/test_util.h"

namespace wm::tokens {
namespace {
namespace fs = std::filesystem;
using test::ErrorText;
using test::MakeEpisode;
using test::MakeTokenDataset;

TEST(TokenDataset, RoundTripsTokensAndStepsAcrossParts) {
  test::TempDir dir;
  auto written = MakeTokenDataset(dir.path().string(), 7, 3, 2, 3, 1024, 5);
  TokenDataset d(dir.path().string());
  ASSERT_EQ(d.num_episodes(), 7);
  EXPECT_EQ(d.index().num_parts, 3);
  EXPECT_EQ(d.tokens_per_frame(), 6);
  for (int64_t k = 0; k < 7; ++k) {
    const TokenEpisode& e = d.episode(k);
    Episode expected = MakeEpisode(3 + static_cast<int>(k % 4), 5 + k, "ep" + std::to_string(k));
    EXPECT_EQ(e.episode_key, expected.episode_key);
    EXPECT_EQ(e.source_episode, k);
    EXPECT_EQ(e.policy_id, "policy" + std::to_string(k % 2));
    std::vector<int64_t> tokens(written[k].size());
    d.CopyTokens(k, 0, e.num_frames, tokens.data());
    EXPECT_TRUE(std::equal(tokens.begin(), tokens.end(), written[k].begin()));
    for (int64_t i = 0; i < e.num_frames * 7; ++i) EXPECT_EQ(d.actions(k)[i], expected.actions[i]);
    for (int64_t t = 0; t < e.num_frames; ++t) {
      EXPECT_EQ(d.rewards(k)[t], expected.rewards[t]);
      EXPECT_EQ(d.is_first(k)[t], expected.is_first[t]);
      EXPECT_EQ(d.is_last(k)[t], expected.is_last[t]);
      EXPECT_EQ(d.is_terminal(k)[t], expected.is_terminal[t]);
    }
  }
  // A sub-range starts at the right frame.
  std::vector<int64_t> tail(6);
  d.CopyTokens(6, 2, 1, tail.data());
  EXPECT_TRUE(std::equal(tail.begin(), tail.end(), written[6].begin() + 12));
}

TEST(TokenDataset, WideTokensUseUint32) {
  test::TempDir dir;
  auto written = MakeTokenDataset(dir.path().string(), 2, 1, 2, 2, 100000, 1);
  TokenDataset d(dir.path().string());
  EXPECT_EQ(d.index().token_dtype, "uint32");
  std::vector<int64_t> tokens(written[1].size());
  d.CopyTokens(1, 0, d.episode(1).num_frames, tokens.data());
  EXPECT_TRUE(std::equal(tokens.begin(), tokens.end(), written[1].begin()));
}

TEST(TokenDataset, IndexAppearsOnlyWhenAllPartsExist) {
  test::TempDir dir;
  MakeTokenDataset(dir.path().string(), 4, 2, 2, 2, 16, 1);
  fs::remove(dir / "index.json");
  fs::remove(dir / "part-00001.json");
  TokenIndex base;
  base.tokenizer.checkpoint_sha256 = "ckpt";
  EXPECT_FALSE(AssembleIndexIfComplete(dir.path().string(), 2, base));
  EXPECT_FALSE(fs::exists(dir / "index.json"));
  EXPECT_NE(ErrorText([&] { TokenDataset d(dir.path().string()); }).find("index.json is missing"),
            std::string::npos);
  // Parts written by a different tokenizer are refused, not mixed in.
  MakeTokenDataset(dir.path().string(), 4, 2, 2, 2, 16, 1);
  base.tokenizer.checkpoint_sha256 = "other";
  base.tokenizer.num_codes = 16;
  EXPECT_NE(ErrorText([&] {
              AssembleIndexIfComplete(dir.path().string(), 2, base);
            }).find("another tokenizer checkpoint"),
            std::string::npos);
}

TEST(TokenDataset, CorruptionIsDetectedAndNamed) {
  test::TempDir dir;
  MakeTokenDataset(dir.path().string(), 3, 1, 2, 2, 16, 2);
  const std::string part = dir / "part-00000.wmtok";
  const uint64_t size = fs::file_size(part);
  test::FlipByte(part, 64 + 3);  // inside the tokens section
  std::string err = ErrorText([&] { TokenDataset d(dir.path().string()); });
  EXPECT_NE(err.find("part-00000.wmtok"), std::string::npos) << err;
  EXPECT_NE(err.find("tokens"), std::string::npos) << err;
  EXPECT_NE(err.find("checksum mismatch"), std::string::npos) << err;
  test::FlipByte(part, 64 + 3);
  test::Truncate(part, size - 1);
  err = ErrorText([&] { TokenDataset d(dir.path().string()); });
  EXPECT_NE(err.find("bytes, index.json says"), std::string::npos) << err;
}

TEST(TokenDataset, RejectsOutOfRangeTokens) {
  test::TempDir dir;
  TokenIndex base;
  base.tokenizer = {.num_codes = 4, .grid_h = 1, .grid_w = 1};
  TokenPartWriter w(dir.path().string(), 0, 1, base);
  Episode e = MakeEpisode(2, 0);
  std::string err = ErrorText([&] { w.AddEpisode({.num_frames = 2}, {1, 4}, e); });
  EXPECT_NE(err.find("out of range"), std::string::npos) << err;
  err = ErrorText([&] { w.AddEpisode({.num_frames = 2}, {1}, e); });
  EXPECT_NE(err.find("token count"), std::string::npos) << err;
  e.rewards.pop_back();
  err = ErrorText([&] { w.AddEpisode({.num_frames = 2}, {1, 2}, e); });
  EXPECT_NE(err.find("per-step arrays"), std::string::npos) << err;
  err = ErrorText([&] { w.AddEpisode({.num_frames = 0}, {}, MakeEpisode(0, 0)); });
  EXPECT_NE(err.find("at least one frame"), std::string::npos) << err;
}

nlohmann::json StatsToJsonOf7() { return shard::StatsToJson(shard::ActionStats{}); }

nlohmann::json ReadIndexJson(const fs::path& dir) {
  return nlohmann::json::parse(ReadFile((dir / "index.json").string()));
}

void WriteIndexJson(const fs::path& dir, const nlohmann::json& j) {
  WriteFileAtomically((dir / "index.json").string(), j.dump(2) + "\n");
}

TEST(TokenDataset, JointActionsKeepTheirWidthInVersion2) {
  test::TempDir dir;
  MakeTokenDataset(dir.path().string(), 3, 2, 2, 2, 16, 1, /*action_dim=*/6);
  const nlohmann::json j = ReadIndexJson(dir.path());
  EXPECT_EQ(j["format_version"], 2);
  EXPECT_EQ(j["action_dim"], 6);
  EXPECT_EQ(j["action_space"], "joint_position");
  EXPECT_EQ(j["parts"][1]["sections"]["actions"]["shape"][1], 6);
  TokenDataset d(dir.path().string());
  EXPECT_EQ(d.action_dim(), 6);
  EXPECT_EQ(d.index().action_space, "joint_position");
  for (int64_t k = 0; k < 3; ++k) {
    for (int64_t i = 0; i < d.episode(k).num_frames * 6; ++i) {
      EXPECT_EQ(d.actions(k)[i], k + i / 100.0f);
    }
  }
}

TEST(TokenDataset, CanonicalActionsKeepTheVersion1Index) {
  test::TempDir dir;
  MakeTokenDataset(dir.path().string(), 2, 1, 2, 2, 16, 1);
  const nlohmann::json j = ReadIndexJson(dir.path());
  EXPECT_EQ(j["format_version"], 1);
  EXPECT_FALSE(j.contains("action_dim") || j.contains("action_space"));
  TokenDataset d(dir.path().string());  // version 1 reads as 7 / eef_delta
  EXPECT_EQ(d.action_dim(), 7);
  EXPECT_EQ(d.index().action_space, "eef_delta");
}

TEST(TokenDataset, ActionWidthErrorsNameTheKey) {
  test::TempDir dir;
  MakeTokenDataset(dir.path().string(), 2, 1, 2, 2, 16, 1, /*action_dim=*/6);
  const nlohmann::json good = ReadIndexJson(dir.path());
  auto error_with = [&](const char* key, const nlohmann::json& value) {
    nlohmann::json j = good;
    j[key] = value;
    WriteIndexJson(dir.path(), j);
    return ErrorText([&] { TokenDataset d(dir.path().string()); });
  };
  std::string err = error_with("action_space", "cartesian");
  EXPECT_NE(err.find("action_space must be eef_delta, joint_position or other"), std::string::npos)
      << err;
  err = error_with("action_dim", 7);  // the stats (and sections) have 6
  EXPECT_NE(err.find("action_stats has 6 values per vector, action_dim is 7"), std::string::npos)
      << err;
  err = error_with("format_version", 4);
  EXPECT_NE(err.find("reads versions 1 to 3"), std::string::npos) << err;
  // A version-1 index means 7 values per action: this one's 6-wide sections are refused.
  nlohmann::json v1 = good;
  v1["format_version"] = 1;
  v1["action_stats"] = StatsToJsonOf7();
  WriteIndexJson(dir.path(), v1);
  err = ErrorText([&] { TokenDataset d(dir.path().string()); });
  EXPECT_NE(err.find("actions"), std::string::npos) << err;
}

TEST(TokenDataset, ResidualLevelsAreStackedPerFrameInVersion3) {
  test::TempDir dir;
  auto written = MakeTokenDataset(dir.path().string(), 5, 2, 2, 3, 1024, 3, kActionDim, 4);
  const nlohmann::json j = ReadIndexJson(dir.path());
  EXPECT_EQ(j["format_version"], 3);
  EXPECT_EQ(j["tokenizer"]["levels"], 4);
  EXPECT_EQ(j["action_dim"], 7);  // version 3 records the action even when canonical
  const int64_t frames = j["parts"][0]["num_frames"];
  EXPECT_EQ(j["parts"][0]["sections"]["tokens"]["shape"], nlohmann::json({frames, 4, 2, 3}));
  const std::string part = ReadFile((dir.path() / PartFileName(0)).string());
  EXPECT_EQ(static_cast<uint8_t>(part[24]), 4);  // the header's levels
  TokenDataset d(dir.path().string());
  EXPECT_EQ(d.index().tokenizer.levels, 4);
  EXPECT_EQ(d.tokens_per_frame(), 24);
  for (int64_t k = 0; k < 5; ++k) {
    std::vector<int64_t> tokens(written[k].size());
    d.CopyTokens(k, 0, d.episode(k).num_frames, tokens.data());
    EXPECT_TRUE(std::equal(tokens.begin(), tokens.end(), written[k].begin())) << k;
  }
  std::vector<int64_t> second(24);  // frame 1 of episode 4: all four levels of it
  d.CopyTokens(4, 1, 1, second.data());
  EXPECT_TRUE(std::equal(second.begin(), second.end(), written[4].begin() + 24));
}

TEST(TokenDataset, LevelErrorsNameTheKey) {
  test::TempDir dir;
  MakeTokenDataset(dir.path().string(), 2, 1, 2, 2, 16, 1, kActionDim, 3);
  const nlohmann::json good = ReadIndexJson(dir.path());
  auto error_with = [&](const nlohmann::json& j) {
    WriteIndexJson(dir.path(), j);
    return ErrorText([&] { TokenDataset d(dir.path().string()); });
  };
  nlohmann::json j = good;
  j["tokenizer"].erase("levels");
  std::string err = error_with(j);
  EXPECT_NE(err.find("format_version 3 needs tokenizer.levels in [2, 8], got 1"), std::string::npos)
      << err;
  EXPECT_NE(err.find("tokenizer.levels"), std::string::npos) << err;
  j = good;
  j["format_version"] = 2;  // a version-2 reader would take the stacks for a larger grid
  err = error_with(j);
  EXPECT_NE(err.find("tokenizer.levels is only written by format_version 3"), std::string::npos)
      << err;
  j = good;
  j["tokenizer"]["levels"] = 2;  // the part's header and tokens section say 3
  err = error_with(j);
  EXPECT_NE(err.find("levels differ from index.json"), std::string::npos) << err;
  EXPECT_NE(err.find("part-00000.wmtok"), std::string::npos) << err;
}

TEST(PartEpisodeRange, CoversEveryEpisodeOnce) {
  for (int n : {1, 2, 3, 7}) {
    int64_t next = 0;
    for (int p = 0; p < n; ++p) {
      auto [first, last] = PartEpisodeRange(10, p, n);
      EXPECT_EQ(first, next);
      next = last;
    }
    EXPECT_EQ(next, 10);
  }
}

}  // namespace
}  // namespace wm::tokens

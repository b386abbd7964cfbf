// wm-sim-policy's library: the closed loop shows the dataset's frames and starts from
// wm-gen-tabletop's episodes, runs are byte-reproducible, the colour policy succeeds where the
// random policy fails, and a failing policy leaves nothing that looks finished.
#include "ingest/tabletop/sim_policy.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"
#include "ingest/tabletop/closed_loop.h"
#include "tests/core/test_util.h"

namespace wm::tabletop {
namespace {

namespace fs = std::filesystem;

std::string Script(const std::string& args) {
  return "/usr/bin/python3 " + test::SourceDir() + "/" + args;
}

SimPolicyOptions Options(const std::string& out, int episodes) {
  SimPolicyOptions o;
  o.out_dir = out;
  o.episodes = episodes;
  o.size = 64;
  o.look = LookVariation::kPlain;
  return o;
}

TEST(ClosedLoopTest, ShowsTheDatasetsFramesFromTheGeneratorsEpisodes) {
  const uint64_t seed = EpisodeSeed(0, "val", 3);
  std::vector<std::vector<uint8_t>> seen;
  const ClosedLoopEpisode e =
      RollOutClosedLoop(seed, 3, LookVariation::kPlain, 64, [&](const ImageObservation& o) {
        seen.push_back(o.rgb);
        return Action{0, 0, 0.04f, 0, 0, 0, 0};
      });
  const Rollout generated = RollOut(seed, PolicyKind::kExpert, 3, LookVariation::kPlain);
  ASSERT_EQ(e.frames.size(), 3u);
  EXPECT_EQ(e.frames[0].jpeg,
            RenderEncodedFrame({generated.steps[0].state, generated.look}, 64).jpeg);
  EXPECT_EQ(e.rollout.look.instruction, generated.look.instruction);
  ASSERT_EQ(seen.size(), 3u);
  for (size_t t = 0; t < seen.size(); ++t) EXPECT_EQ(seen[t], DecodeJpegRgb(e.frames[t].jpeg, 64));
  EXPECT_FLOAT_EQ(e.rollout.steps[1].state.ee.z - e.rollout.steps[0].state.ee.z, 0.04f);
}

TEST(SimPolicyTest, SameOptionsGiveIdenticalBytes) {
  test::TempDir a, b;
  for (const test::TempDir* dir : {&a, &b}) {
    SimPolicyOptions o = Options(dir->path().string(), 3);
    o.policies = {{"noisy", Script("scripts/tabletop_colour_policy.py --noise 0.15"), false, ""}};
    RunSimPolicies(o);
  }
  for (const char* file : {"policy_values.json", "policy_values.csv", "policy_episodes.csv",
                           "wm_tabletop_sim/1.0.0/dataset_info.json",
                           "wm_tabletop_sim/1.0.0/wm_tabletop_sim-noisy.tfrecord-00000-of-00001"}) {
    EXPECT_EQ(ReadFile(a / file), ReadFile(b / file)) << file;
  }
}

TEST(SimPolicyTest, ColourPolicySucceedsWhereRandomFails) {
  test::TempDir dir;
  SimPolicyOptions o = Options(dir.path().string(), 16);
  o.write_dataset = false;
  o.policies = {{"colour", Script("scripts/tabletop_colour_policy.py --noise 0"), true, ""},
                {"random", Script("scripts/tabletop_colour_policy.py --random"), true, ""}};
  const std::vector<PolicyTruth> t = RunSimPolicies(o);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_GE(t[0].successes, 11) << "colour policy at noise 0";
  EXPECT_LE(t[1].successes, 2) << "random policy";
  EXPECT_LE(t[0].ci_low, t[0].true_value);
  EXPECT_GE(t[0].ci_high, t[0].true_value);
  EXPECT_FALSE(fs::exists(dir / "wm_tabletop_sim/1.0.0/dataset_info.json"));
  EXPECT_TRUE(fs::exists(dir / "policy_values.json"));
}

TEST(SimPolicyTest, FailingPolicyLeavesNothingThatLooksFinished) {
  test::TempDir dir;
  SimPolicyOptions o = Options(dir.path().string(), 2);
  o.policies = {{"good", Script("scripts/wmpolicy.py"), false, ""}};
  RunSimPolicies(o);  // an earlier, finished run
  ASSERT_TRUE(fs::exists(dir / "policy_values.json"));
  o.policies.push_back(
      {"crashing", Script("tests/policy/echo_policy.py --bad crash --at 3"), false, ""});
  EXPECT_THAT(test::ErrorText([&] { RunSimPolicies(o); }),
              ::testing::HasSubstr("policy 'crashing', episode 0, step 3: exited with status 3"));
  for (const char* file :
       {"policy_values.json", "policy_values.csv", "policy_episodes.csv",
        "wm_tabletop_sim/1.0.0/dataset_info.json",
        "wm_tabletop_sim/1.0.0/wm_tabletop_sim-crashing.tfrecord-00000-of-00001"}) {
    EXPECT_FALSE(fs::exists(dir / file)) << file;
  }
}

}  // namespace
}  // namespace wm::tabletop

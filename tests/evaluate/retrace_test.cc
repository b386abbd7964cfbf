// Retracing rollout context construction (whale-x.txt section 3.4) on hand-written sequences.
#include "evaluate/retrace.h"

#include <gtest/gtest.h>

#include "core/tokens/token_dataset.h"
#include "evaluate/rollout.h"
#include "tests/core/test_util.h"

namespace wm::evaluate {
namespace {

// Action i = (i+1, 10(i+1), 0, 0, 0, -(i+1), gripper i % 2).
std::vector<float> Ramp(int n) {
  std::vector<float> a;
  for (int i = 0; i < n; ++i) {
    const float v = static_cast<float>(i + 1);
    a.insert(a.end(), {v, 10 * v, 0, 0, 0, -v, static_cast<float>(i % 2)});
  }
  return a;
}

std::vector<int64_t> Frames(const std::vector<ContextSlot>& slots) {
  std::vector<int64_t> f;
  for (const auto& s : slots) f.push_back(s.frame);
  return f;
}

void ExpectSameSlots(const std::vector<ContextSlot>& a, const std::vector<ContextSlot>& b,
                     int64_t t) {
  ASSERT_EQ(Frames(a), Frames(b)) << "t = " << t;
  for (size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].action, b[i].action) << t << " " << i;
}

TEST(Retrace, ActionSumsDeltasAndKeepsTheLastGripper) {
  auto a = Ramp(4);
  Action r = RetraceAction(a.data(), kActionDim, 3);  // actions 1, 2, 3 (1-based values)
  EXPECT_EQ(r, (Action{6, 60, 0, 0, 0, -6, 0}));      // gripper of action index 2 = 2 % 2 = 0
  EXPECT_EQ(RetraceAction(a.data(), kActionDim, 4)[6], 1.f);
  EXPECT_EQ(RetraceAction(a.data(), kActionDim, 1), (Action{1, 10, 0, 0, 0, -1, 0}));
  EXPECT_NE(test::ErrorText([&] { RetraceAction(a.data(), kActionDim, 0); }), "(no error)");
}

TEST(Retrace, PlainWindowSlides) {
  auto a = Ramp(10);
  EXPECT_EQ(Frames(PlainContext(a.data(), kActionDim, 0, 4)), (std::vector<int64_t>{0}));
  EXPECT_EQ(Frames(PlainContext(a.data(), kActionDim, 2, 4)), (std::vector<int64_t>{0, 1, 2}));
  EXPECT_EQ(Frames(PlainContext(a.data(), kActionDim, 7, 4)), (std::vector<int64_t>{4, 5, 6, 7}));
  EXPECT_EQ(PlainContext(a.data(), kActionDim, 7, 4)[0].action[0], 5.f);  // action index 4
}

TEST(Retrace, MatchesThePapersExample) {
  // whale-x.txt: C = 4, predicting o_{t+1} (1-based) uses (o_1, retrace(a_1..a_{t-3}),
  // o_{t-2}, a_{t-2}, o_{t-1}, a_{t-1}, o_t, a_t). 0-based with t = 7: frame 0 with
  // retrace(a_0..a_4), then frames 5, 6, 7.
  auto a = Ramp(10);
  auto slots = RetraceContext(a.data(), kActionDim, 7, 4);
  EXPECT_EQ(Frames(slots), (std::vector<int64_t>{0, 5, 6, 7}));
  EXPECT_EQ(slots[0].action, (Action{15, 150, 0, 0, 0, -15, 0}));  // 1+2+3+4+5; a_4 gripper 0
  EXPECT_EQ(slots[1].action[0], 6.f);
  EXPECT_EQ(slots[3].action[0], 8.f);
}

TEST(Retrace, EqualsPlainWhileFrameZeroIsStillInTheWindow) {
  auto a = Ramp(10);
  for (int64_t t = 0; t < 4; ++t) {
    ExpectSameSlots(PlainContext(a.data(), kActionDim, t, 4),
                    RetraceContext(a.data(), kActionDim, t, 4), t);
  }
  // First divergence: t = C, where the plain window drops frame 0.
  EXPECT_EQ(Frames(RetraceContext(a.data(), kActionDim, 4, 4)), (std::vector<int64_t>{0, 2, 3, 4}));
  EXPECT_EQ(RetraceContext(a.data(), kActionDim, 4, 4)[0].action[0], 3.f);  // a_0 + a_1 = 1 + 2
}

// wm-eval --retrace-ks: frame 0, then the newest `kept` frames; the t - kept + 1 older steps
// folded into the anchor's action. Ramp's a_i[0] = i + 1.
TEST(Retrace, AnchoredContextKeepsTheNewestFramesAndFoldsTheRest) {
  auto a = Ramp(10);
  auto k0 = AnchoredContext(a.data(), kActionDim, 5, 0);  // frame 0 straight to frame 6
  EXPECT_EQ(Frames(k0), (std::vector<int64_t>{0}));
  EXPECT_EQ(k0[0].action, (Action{21, 210, 0, 0, 0, -21, 1}));  // a_0..a_5; a_5 gripper 1
  auto k2 = AnchoredContext(a.data(), kActionDim, 5, 2);        // a_0..a_3 folded, then frames 4, 5
  EXPECT_EQ(Frames(k2), (std::vector<int64_t>{0, 4, 5}));
  EXPECT_EQ(k2[0].action, (Action{10, 100, 0, 0, 0, -10, 1}));  // a_3 gripper 1
  EXPECT_EQ(k2[1].action[0], 5.f);
  EXPECT_EQ(k2[2].action[0], 6.f);
  // Nothing to fold once kept >= t: frames 0..t with their own actions.
  auto k5 = AnchoredContext(a.data(), kActionDim, 3, 5);
  EXPECT_EQ(Frames(k5), (std::vector<int64_t>{0, 1, 2, 3}));
  EXPECT_EQ(k5[0].action[0], 1.f);
  EXPECT_EQ(Frames(AnchoredContext(a.data(), kActionDim, 3, 3)), Frames(k5));
  EXPECT_NE(test::ErrorText([&] { AnchoredContext(a.data(), kActionDim, 3, -1); }), "(no error)");
}

// The retracing rollout's context is the anchored one with C - 1 kept frames, slot for slot.
TEST(Retrace, RetraceContextIsAnchoredWithContextMinusOneKept) {
  auto a = Ramp(12);
  for (int64_t t = 4; t < 11; ++t) {
    ExpectSameSlots(RetraceContext(a.data(), kActionDim, t, 4),
                    AnchoredContext(a.data(), kActionDim, t, 3), t);
  }
}

TEST(Retrace, SumsEveryDeltaButTheLastValueAtAnyWidth) {
  const std::vector<float> a = {1, 2, 1, 3, 4, 0};  // two 3-value eef_delta actions
  EXPECT_EQ(RetraceAction(a.data(), 3, 2), (Action{4, 6, 0}));
  EXPECT_EQ(PlainContext(a.data(), 3, 1, 4)[1].action, (Action{3, 4, 0}));
}

// WHALE eq. 6 adds end-effector deltas; summing joint positions means nothing, so wm-eval
// refuses a retracing rollout of such data with one line naming the dataset and its space.
TEST(Retrace, RefusesActionsThatAreNotEndEffectorDeltas) {
  test::TempDir dir;
  test::MakeTokenDataset(dir.path().string(), 2, 1, 2, 2, 16, 1, /*action_dim=*/6);
  const tokens::TokenDataset joints(dir.path().string());
  const std::string err =
      test::ErrorText([&] { CheckRolloutModeFits(RolloutMode::kRetrace, joints); });
  EXPECT_NE(err.find("retrace (WHALE eq. 6) sums end-effector deltas, but dataset 'unit' has "
                     "joint_position actions (use --rollout plain)"),
            std::string::npos)
      << err;
  EXPECT_EQ(err.find('\n'), std::string::npos);
  CheckRolloutModeFits(RolloutMode::kPlain, joints);
  EXPECT_EQ(AutoRolloutModes(dir.path().string()), std::vector<RolloutMode>{RolloutMode::kPlain});
  test::TempDir eef;
  test::MakeTokenDataset(eef.path().string(), 2, 1, 2, 2, 16, 1);
  EXPECT_EQ(AutoRolloutModes(eef.path().string()),
            (std::vector<RolloutMode>{RolloutMode::kPlain, RolloutMode::kRetrace}));
}

}  // namespace
}  // namespace wm::evaluate

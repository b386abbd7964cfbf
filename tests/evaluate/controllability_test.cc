// Controllability's perturbed actions (evaluate/controllability.h) on hand-written sequences.
#include "evaluate/controllability.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "core/episode.h"
#include "core/error.h"

namespace wm::evaluate {
namespace {

// Action i = (i, 10 i, 0, 0, 0, -i, i % 2).
std::vector<float> Ramp(int n) {
  std::vector<float> a;
  for (int i = 0; i < n; ++i) {
    const auto v = static_cast<float>(i);
    a.insert(a.end(), {v, 10 * v, 0, 0, 0, -v, static_cast<float>(i % 2)});
  }
  return a;
}

// Which original action each row holds (its dim 0).
std::vector<int> Order(const std::vector<float>& actions) {
  std::vector<int> order;
  for (size_t i = 0; i < actions.size(); i += kActionDim) {
    order.push_back(static_cast<int>(actions[i]));
  }
  return order;
}

TEST(PerturbActions, ReversedReversesEveryActionThatLeadsToAFrame) {
  const auto a = Ramp(6);  // 6 frames: actions 0..4 lead to frames 1..5, action 5 nowhere
  const auto r = PerturbActions(a.data(), kActionDim, 6, Perturbation::kReversed, 0, 0);
  EXPECT_EQ(Order(r), (std::vector<int>{4, 3, 2, 1, 0, 5}));
  EXPECT_EQ(std::vector<float>(r.begin(), r.begin() + kActionDim),
            std::vector<float>(a.begin() + 4 * kActionDim, a.begin() + 5 * kActionDim));
  EXPECT_EQ(PerturbActions(a.data(), kActionDim, 6, Perturbation::kOff, 0, 0), a);
  // Two frames: one action leads anywhere, nothing to reorder.
  EXPECT_EQ(PerturbActions(a.data(), kActionDim, 2, Perturbation::kReversed, 0, 0),
            std::vector<float>(a.begin(), a.begin() + 2 * kActionDim));
  EXPECT_EQ(PerturbActions(a.data(), kActionDim, 2, Perturbation::kShuffled, 0, 0),
            std::vector<float>(a.begin(), a.begin() + 2 * kActionDim));
}

TEST(PerturbActions, ShuffledIsTheDocumentedSeededFisherYatesPerEpisode) {
  const auto a = Ramp(10);
  const auto s = PerturbActions(a.data(), kActionDim, 10, Perturbation::kShuffled, 7, 3);
  // docs/reports.md: std::mt19937_64 seeded with MixSeed(MixSeed(seed, episode), -1); for i from
  // T-2 down to 1 swap rows i and rng() % (i + 1).
  std::mt19937_64 rng(MixSeed(MixSeed(7, 3), -1));
  std::vector<int> want = {0, 1, 2, 3, 4, 5, 6, 7, 8};
  for (int i = 8; i > 0; --i) std::swap(want[i], want[rng() % static_cast<uint64_t>(i + 1)]);
  want.push_back(9);
  EXPECT_EQ(Order(s), want);
  std::vector<int> sorted = Order(s);
  std::sort(sorted.begin(), sorted.end());
  EXPECT_EQ(sorted, Order(a));  // a permutation: the same actions in another order
  EXPECT_NE(Order(s), Order(a));
  const auto shuffled = [&](int64_t episode) {
    return PerturbActions(a.data(), kActionDim, 10, Perturbation::kShuffled, 7, episode);
  };
  EXPECT_EQ(shuffled(3), s);  // seeded
  EXPECT_NE(shuffled(4), s);  // per episode
}

TEST(Perturbation, NamesRoundTripAndUnknownNamesAreErrors) {
  for (auto p : {Perturbation::kOff, Perturbation::kReversed, Perturbation::kShuffled}) {
    EXPECT_EQ(ParsePerturbation(PerturbationName(p)), p);
  }
  EXPECT_THROW(ParsePerturbation("sideways"), Error);
}

}  // namespace
}  // namespace wm::evaluate

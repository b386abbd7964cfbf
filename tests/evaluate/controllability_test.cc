// Controllability's perturbed actions (evaluate/controllability.h) on hand-written sequences.
#include "evaluate/controllability.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

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

TEST(PerturbActions, ReversedReversesTheFirstStepsRowsAndKeepsTheRest) {
  const auto a = Ramp(6);
  const auto r = PerturbActions(a.data(), 6, 4, Perturbation::kReversed, 0, 0);
  EXPECT_EQ(Order(r), (std::vector<int>{3, 2, 1, 0, 4, 5}));
  EXPECT_EQ(std::vector<float>(r.begin(), r.begin() + kActionDim),
            std::vector<float>(a.begin() + 3 * kActionDim, a.begin() + 4 * kActionDim));
  EXPECT_EQ(PerturbActions(a.data(), 6, 4, Perturbation::kOff, 0, 0), a);
  // One step: nothing to reorder, so a rollout given these actions is the plain one.
  EXPECT_EQ(PerturbActions(a.data(), 6, 1, Perturbation::kReversed, 0, 0), a);
  EXPECT_EQ(PerturbActions(a.data(), 6, 1, Perturbation::kShuffled, 0, 0), a);
}

TEST(PerturbActions, ShuffledIsTheDocumentedSeededFisherYatesPerEpisode) {
  const auto a = Ramp(10);
  const auto s = PerturbActions(a.data(), 10, 8, Perturbation::kShuffled, 7, 3);
  // docs/reports.md: std::mt19937_64 seeded with MixSeed(MixSeed(seed, episode), -1); for i from
  // H-1 down to 1 swap rows i and rng() % (i + 1).
  std::mt19937_64 rng(MixSeed(MixSeed(7, 3), -1));
  std::vector<int> want = {0, 1, 2, 3, 4, 5, 6, 7};
  for (int i = 7; i > 0; --i) std::swap(want[i], want[rng() % static_cast<uint64_t>(i + 1)]);
  want.insert(want.end(), {8, 9});
  EXPECT_EQ(Order(s), want);
  std::vector<int> sorted = Order(s);
  std::sort(sorted.begin(), sorted.end());
  EXPECT_EQ(sorted, Order(a));  // a permutation: the same actions in another order
  EXPECT_NE(Order(s), Order(a));
  EXPECT_EQ(PerturbActions(a.data(), 10, 8, Perturbation::kShuffled, 7, 3), s);  // seeded
  EXPECT_NE(PerturbActions(a.data(), 10, 8, Perturbation::kShuffled, 7, 4), s);  // per episode
}

TEST(Perturbation, NamesRoundTripAndUnknownNamesAreErrors) {
  for (auto p : {Perturbation::kOff, Perturbation::kReversed, Perturbation::kShuffled}) {
    EXPECT_EQ(ParsePerturbation(PerturbationName(p)), p);
  }
  EXPECT_THROW(ParsePerturbation("sideways"), Error);
}

}  // namespace
}  // namespace wm::evaluate

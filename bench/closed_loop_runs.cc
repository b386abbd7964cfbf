#include "bench/closed_loop_runs.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace wm::bench {
namespace {

namespace ev = evaluate;

Run Timed(Clock::time_point t0, std::vector<ev::ClosedLoopRollout> rollouts) {
  Run run{.rollouts = std::move(rollouts), .seconds = Seconds(t0)};
  for (const auto& r : run.rollouts) run.frames += r.steps;
  return run;
}

// The first frame where two rollouts differ by more than float rounding (their length if none).
int64_t FirstDifferentFrame(const ev::ClosedLoopRollout& a, const ev::ClosedLoopRollout& b) {
  const size_t frame = static_cast<size_t>(3) * a.frames.size * a.frames.size;
  const size_t n = std::min(a.frames.pixels.size(), b.frames.pixels.size()) / frame;
  for (size_t f = 0; f < n; ++f) {
    for (size_t k = f * frame; k < (f + 1) * frame; ++k) {
      if (std::abs(a.frames.pixels[k] - b.frames.pixels[k]) > 1e-4) return static_cast<int64_t>(f);
    }
  }
  return static_cast<int64_t>(n);
}

double MaxAbsDiff(const std::vector<float>& a, const std::vector<float>& b) {
  double most = 0;
  for (size_t k = 0; k < std::min(a.size(), b.size()); ++k) {
    most = std::max<double>(most, std::abs(a[k] - b[k]));
  }
  return most;
}

}  // namespace

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

void PrintSpeed(const char* name, const Run& run, const char* ratio_name, double ratio) {
  std::printf("%s: %lld frames in %.2f s = %.1f frames/s; %s = %.2fx\n", name,
              static_cast<long long>(run.frames), run.seconds, run.Rate(), ratio_name, ratio);
}

Run OneAtATime(const ev::WorldFactory& worlds, policy::PolicyProcess& policy,
               const std::vector<ev::ClosedLoopStart>& starts, const ev::ClosedLoopOptions& o) {
  const auto t0 = Clock::now();
  std::vector<ev::ClosedLoopRollout> rollouts;
  rollouts.reserve(starts.size());
  for (const auto& s : starts)
    rollouts.push_back(ev::RunClosedLoop(*worlds(s, 0), policy, s, 0, o));
  return Timed(t0, std::move(rollouts));
}

Run Batched(const ev::WorldsFactory& worlds, policy::PolicyProcess& policy,
            const std::vector<ev::ClosedLoopStart>& starts, const ev::ClosedLoopOptions& o) {
  const auto t0 = Clock::now();
  std::vector<ev::ClosedLoopRollout> rollouts;
  const auto batch = static_cast<size_t>(o.batch);
  for (size_t first = 0; first < starts.size(); first += batch) {
    std::vector<const ev::ClosedLoopStart*> group;
    for (size_t i = first; i < std::min(starts.size(), first + batch); ++i)
      group.push_back(&starts[i]);
    for (auto& r : ev::RunClosedLoops(*worlds(group, 0), policy, group, 0, o)) {
      rollouts.push_back(std::move(r));
    }
  }
  return Timed(t0, std::move(rollouts));
}

void Compare(const Run& ref, const Run& fast, const char* what) {
  double reward = 0, pixel = 0, action = 0, first_different = 0;
  int same_end = 0;
  for (size_t i = 0; i < ref.rollouts.size(); ++i) {
    const auto &a = ref.rollouts[i], &b = fast.rollouts[i];
    same_end += a.steps == b.steps && a.end == b.end;
    first_different += FirstDifferentFrame(a, b) / double(ref.rollouts.size());
    reward = std::max(reward, MaxAbsDiff(a.rewards, b.rewards));
    pixel = std::max(pixel, MaxAbsDiff(a.frames.pixels, b.frames.pixels));
    action = std::max(action, MaxAbsDiff(a.actions, b.actions));
  }
  std::printf(
      "%s: %d/%zu rollouts end alike; max |reward diff| %.3g, max |pixel diff| %.3g (of "
      "[-1, 1]), max |action diff| %.3g; frames equal up to frame %.1f on average\n",
      what, same_end, ref.rollouts.size(), reward, pixel, action, first_different);
}

}  // namespace wm::bench

#pragma once
// What the closed-loop imagination benchmarks share (imagination_bench for the token model,
// motion_imagination_bench for the motion model): timed runs of one world model's two paths over
// the same starts and policy, one episode at a time and in lockstep batches, and how far apart
// their rollouts are.
#include <chrono>
#include <cstdint>
#include <vector>

#include "evaluate/closed_loop.h"

namespace wm::bench {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point since);

// The rollouts of one path over every start, and how long they took.
struct Run {
  std::vector<evaluate::ClosedLoopRollout> rollouts;
  double seconds = 0;
  int64_t frames = 0;                               // imagined frames: the rollouts' steps
  double Rate() const { return frames / seconds; }  // imagined frames/s
};

// "NAME: F frames in S s = R frames/s; RATIO_NAME = RATIO x".
void PrintSpeed(const char* name, const Run& run, const char* ratio_name, double ratio);

// Rollout 0 of each start in turn, a fresh world each (RunClosedLoop).
Run OneAtATime(const evaluate::WorldFactory& worlds, policy::PolicyProcess& policy,
               const std::vector<evaluate::ClosedLoopStart>& starts,
               const evaluate::ClosedLoopOptions& o);

// Rollout 0 of the starts in lockstep batches of o.batch, as wm-eval --policy runs them.
Run Batched(const evaluate::WorldsFactory& worlds, policy::PolicyProcess& policy,
            const std::vector<evaluate::ClosedLoopStart>& starts,
            const evaluate::ClosedLoopOptions& o);

// Prints how far the `fast` rollouts are from the `ref` ones: ends, rewards, pixels, actions.
void Compare(const Run& ref, const Run& fast, const char* what);

}  // namespace wm::bench

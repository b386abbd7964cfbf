#pragma once
// SplitMix64's finalizer (Steele, Lea & Flood 2014): decorrelates nearby inputs (seed 0 vs 1,
// episode 7 vs 8). Shared by the tabletop generator and the policy seeds that the simulator and
// the world model's policy evaluation must derive identically.
#include <cstdint>

namespace wm {

inline uint64_t MixBits(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

}  // namespace wm

#pragma once
// Internal to wm_metrics: a minimal fork-join loop. Metrics split work into independent items
// (frames, channel rows) whose results land in per-item slots, so outputs do not depend on the
// thread count.
#include <algorithm>
#include <atomic>
#include <cstdint>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace wm::metrics::internal {

// 0 -> the number of hardware threads (at least 1).
inline int ResolveThreads(int threads) {
  if (threads > 0) return threads;
  return std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

// Calls fn(i) for i in [0, count) on up to `threads` threads (the caller's included). The first
// exception thrown by any call is rethrown here after all threads have stopped.
template <typename Fn>
void ParallelFor(int64_t count, int threads, Fn&& fn) {
  const int workers = static_cast<int>(std::min<int64_t>(ResolveThreads(threads), count));
  if (workers <= 1) {
    for (int64_t i = 0; i < count; ++i) fn(i);
    return;
  }
  std::atomic<int64_t> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto work = [&] {
    for (int64_t i = next++; i < count; i = next++) {
      try {
        fn(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
        next = count;  // stop handing out work
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < workers; ++t) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace wm::metrics::internal

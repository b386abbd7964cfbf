// ReadAhead: the items are load(k) whatever was started ahead, the next one is read on another
// thread before it is asked for, and nothing at or past the end is read.
#include "core/read_ahead.h"

#include <gtest/gtest.h>

#include <chrono>
#include <future>
#include <mutex>
#include <thread>
#include <vector>

namespace wm {
namespace {

// A loader that records which indices it read and on which thread.
struct RecordingLoader {
  std::mutex mu;
  std::vector<int64_t> loaded;
  std::vector<std::thread::id> threads;

  int64_t Load(int64_t k) {
    std::lock_guard<std::mutex> lock(mu);
    loaded.push_back(k);
    threads.push_back(std::this_thread::get_id());
    return 10 * k;
  }
};

TEST(ReadAhead, TakesItemsInOrderAndReadsNoneAtOrPastTheEnd) {
  RecordingLoader loader;
  ReadAhead<int64_t> items;
  auto load = [&](int64_t k) { return loader.Load(k); };
  for (int64_t k = 3; k < 7; ++k) EXPECT_EQ(items.Take(k, 7, load), 10 * k);
  std::lock_guard<std::mutex> lock(loader.mu);
  EXPECT_EQ(loader.loaded, (std::vector<int64_t>{3, 4, 5, 6}));  // each once, none at 7
  for (const std::thread::id& id : loader.threads) EXPECT_NE(id, std::this_thread::get_id());
}

TEST(ReadAhead, StartsTheNextItemBeforeItIsAskedFor) {
  std::promise<void> next_started;
  ReadAhead<int64_t> items;
  auto load = [&](int64_t k) {
    if (k == 1) next_started.set_value();
    return k;
  };
  EXPECT_EQ(items.Take(0, 2, load), 0);
  // Item 1 is read before it is taken (a minute is only a guard against hanging forever).
  EXPECT_EQ(next_started.get_future().wait_for(std::chrono::seconds(60)),
            std::future_status::ready);
  EXPECT_EQ(items.Take(1, 2, load), 1);
}

TEST(ReadAhead, AnItemOutOfOrderIsReadAgainNotTakenFromTheOneAhead) {
  RecordingLoader loader;
  ReadAhead<int64_t> items;
  auto load = [&](int64_t k) { return loader.Load(k); };
  EXPECT_EQ(items.Take(0, 10, load), 0);  // starts item 1
  EXPECT_EQ(items.Take(5, 10, load), 50);
  EXPECT_EQ(items.Take(6, 10, load), 60);
}

}  // namespace
}  // namespace wm

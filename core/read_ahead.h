#pragma once
// Reading item k + 1 on another thread while item k is used: a trainer decodes its next batch
// while this one trains, the encoder reads its next episode while this one encodes. Each item
// depends only on its index, so the items are the same as reading them in order.
#include <cstdint>
#include <future>
#include <utility>

namespace wm {

template <class T>
class ReadAhead {
 public:
  // Item `k`, read by `load(k)` (waiting for it when it was started ahead); then starts
  // load(k + 1) on another thread when k + 1 < `end`. `load` is copied into that thread and must
  // be safe to run beside the caller until the next Take.
  template <class Load>
  T Take(int64_t k, int64_t end, const Load& load) {
    if (!pending_.valid() || pending_index_ != k) Start(k, load);
    T item = pending_.get();
    if (k + 1 < end) Start(k + 1, load);
    return item;
  }

 private:
  template <class Load>
  void Start(int64_t k, const Load& load) {
    pending_ = std::async(std::launch::async, load, k);  // waits for a stale one first
    pending_index_ = k;
  }

  std::future<T> pending_;
  int64_t pending_index_ = -1;
};

}  // namespace wm

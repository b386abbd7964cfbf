#pragma once
// Loads items on worker threads while the caller consumes them strictly in input order, with at
// most `window` items in flight (bounded memory). Output order never depends on thread timing.
#include <condition_variable>
#include <functional>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

namespace wm::ingest {

template <typename Result>
class OrderedLoader {
 public:
  // Starts `threads` workers calling load(i) for i in [begin, end).
  OrderedLoader(size_t begin, size_t end, int threads, size_t window,
                std::function<Result(size_t)> load)
      : next_(begin), consumed_(begin), end_(end), window_(window), load_(std::move(load)) {
    for (int t = 0; t < threads; ++t) workers_.emplace_back([this] { Work(); });
  }
  ~OrderedLoader() {
    {
      std::lock_guard<std::mutex> lock(mu_);
      stop_ = true;
    }
    cv_.notify_all();
    for (auto& w : workers_) w.join();
  }
  OrderedLoader(const OrderedLoader&) = delete;
  OrderedLoader& operator=(const OrderedLoader&) = delete;

  // The result for item i; call with i = begin, begin + 1, ... in order.
  Result Take(size_t i) {
    std::unique_lock<std::mutex> lock(mu_);
    cv_.wait(lock, [&] { return ready_.count(i) > 0; });
    Result r = std::move(ready_.at(i));
    ready_.erase(i);
    consumed_ = i + 1;
    cv_.notify_all();
    return r;
  }

 private:
  void Work() {
    for (;;) {
      size_t i;
      {
        std::unique_lock<std::mutex> lock(mu_);
        cv_.wait(lock, [&] { return stop_ || next_ >= end_ || next_ < consumed_ + window_; });
        if (stop_ || next_ >= end_) return;
        i = next_++;
      }
      Result r = load_(i);
      {
        std::lock_guard<std::mutex> lock(mu_);
        ready_.emplace(i, std::move(r));
      }
      cv_.notify_all();
    }
  }

  std::mutex mu_;
  std::condition_variable cv_;
  std::map<size_t, Result> ready_;
  size_t next_, consumed_, end_, window_;
  bool stop_ = false;
  std::function<Result(size_t)> load_;
  std::vector<std::thread> workers_;
};

}  // namespace wm::ingest

#include "ingest/lerobot/frame_matcher.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "core/error.h"

namespace wm::ingest {

FrameMatcher::FrameMatcher(std::vector<double> step_timestamps, double tolerance_s)
    : timestamps_(std::move(step_timestamps)),
      order_(timestamps_.size()),
      best_distance_(timestamps_.size(), std::numeric_limits<double>::infinity()),
      nearest_frame_(timestamps_.size(), std::numeric_limits<double>::quiet_NaN()),
      tolerance_s_(tolerance_s) {
  std::iota(order_.begin(), order_.end(), size_t{0});
  std::stable_sort(order_.begin(), order_.end(),
                   [&](size_t a, size_t b) { return timestamps_[a] < timestamps_[b]; });
}

void FrameMatcher::Consider(size_t k, double frame_timestamp, std::vector<size_t>& won) {
  const size_t step = order_[k];
  const double d = std::abs(timestamps_[step] - frame_timestamp);
  if (d >= best_distance_[step]) return;
  best_distance_[step] = d;
  nearest_frame_[step] = frame_timestamp;
  if (d < tolerance_s_) won.push_back(step);
}

std::vector<size_t> FrameMatcher::Offer(double t) {
  std::vector<size_t> won;
  auto less = [&](size_t step, double v) { return timestamps_[step] < v; };
  // Steps within tolerance, and the one on each side of the frame (for error messages).
  size_t lo =
      std::lower_bound(order_.begin(), order_.end(), t - tolerance_s_, less) - order_.begin();
  size_t hi =
      std::lower_bound(order_.begin(), order_.end(), t + tolerance_s_, less) - order_.begin();
  if (lo > 0) --lo;
  hi = std::min(hi + 1, order_.size());
  for (size_t k = lo; k < hi; ++k) Consider(k, t, won);
  return won;
}

void FrameMatcher::CheckAllMatched() const {
  for (size_t step = 0; step < timestamps_.size(); ++step) {
    if (best_distance_[step] < tolerance_s_) continue;
    throw Error("step " + std::to_string(step) + " (timestamp " +
                std::to_string(timestamps_[step]) + " s) has no video frame within " +
                std::to_string(tolerance_s_) + " s" +
                (std::isnan(nearest_frame_[step])
                     ? std::string(" (the video has no frames)")
                     : " (nearest frame at " + std::to_string(nearest_frame_[step]) + " s)"));
  }
}

}  // namespace wm::ingest

#pragma once
// Pairs each step's timestamp with the video frame nearest to it, as LeRobotDataset does
// (lerobot/datasets/video_utils.py: the nearest decoded frame must lie within tolerance_s of
// the query, else it raises). Frames arrive one by one in decode order.
#include <cstdint>
#include <string>
#include <vector>

namespace wm::ingest {

class FrameMatcher {
 public:
  FrameMatcher(std::vector<double> step_timestamps, double tolerance_s);

  // The steps this frame is now the nearest frame within tolerance for (usually one, none
  // for a frame no step asks for). The caller stores the frame for each.
  std::vector<size_t> Offer(double frame_timestamp);

  // Throws wm::Error naming the first step without a frame within tolerance, with its
  // timestamp and the nearest frame's.
  void CheckAllMatched() const;

 private:
  void Consider(size_t sorted_position, double frame_timestamp, std::vector<size_t>& won);
  std::vector<double> timestamps_;
  std::vector<size_t> order_;  // step indices sorted by timestamp
  std::vector<double> best_distance_, nearest_frame_;
  double tolerance_s_;
};

}  // namespace wm::ingest

#pragma once
// The tabletop world run closed loop under an image policy: at every step the policy is shown
// exactly the frame the dataset stores (the step's JPEG, decoded to RGB, at the dataset's size
// and look) and its action moves the world. Episodes are the ones wm-gen-tabletop would start
// from the same episode seed (same layout, look and instruction), so a policy's true value can
// be measured from the real first frames of a held-out split.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "ingest/tabletop/episode.h"

namespace wm::tabletop {

// What an image policy is given at one step.
struct ImageObservation {
  const std::vector<uint8_t>& rgb;  // [size, size, 3] row-major RGB: the decoded dataset JPEG
  int size;
  const std::string& instruction;
  int step;  // 0 for the first frame
};

// Returns the action for an observation: 7 values (Action's layout); StepScene clamps them.
using ImagePolicy = std::function<Action(const ImageObservation&)>;

struct ClosedLoopEpisode {
  Rollout rollout;                   // states, clamped actions, rewards and flags per step
  std::vector<EncodedFrame> frames;  // one per step, as EncodeEpisode stores them
  double episode_return = 0;         // sum of rewards (1 when the block reached the goal)
};

// Runs one episode of at most `max_steps` steps from `episode_seed` (RollOutWith's rules). The
// policy is not asked at a terminal step.
ClosedLoopEpisode RollOutClosedLoop(uint64_t episode_seed, int max_steps, LookVariation look,
                                    int size, const ImagePolicy& policy);

// The RGB pixels of a JPEG as every reader of the dataset decodes it. Throws wm::Error.
std::vector<uint8_t> DecodeJpegRgb(const std::string& jpeg, int size);

}  // namespace wm::tabletop

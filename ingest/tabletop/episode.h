#pragma once
// One tabletop episode: simulated under a scripted policy (states, actions, rewards, flags),
// then rendered and encoded as one tf.train.Example with the flattened keys TFDS writes for an
// RLDS dataset (per-step values concatenated over the steps).
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "ingest/tabletop/policies.h"
#include "ingest/tabletop/scene.h"

namespace wm::tabletop {

// Flattened feature keys (tfds_features.cc declares each of them in features.json).
inline constexpr const char* kImageKey = "steps/observation/image";                // JPEG, RGB
inline constexpr const char* kDepthKey = "steps/observation/depth";                // PNG uint16, mm
inline constexpr const char* kSegmentationKey = "steps/observation/segmentation";  // PNG, Label
inline constexpr const char* kActionKey = "steps/action";  // 7 floats per step, see Action
inline constexpr const char* kRewardKey = "steps/reward";
inline constexpr const char* kDiscountKey = "steps/discount";
inline constexpr const char* kIsFirstKey = "steps/is_first";  // bools as int64, like TFDS
inline constexpr const char* kIsLastKey = "steps/is_last";
inline constexpr const char* kIsTerminalKey = "steps/is_terminal";
inline constexpr const char* kInstructionKey = "steps/language_instruction";
inline constexpr const char* kPolicyIdKey = "episode_metadata/policy_id";
inline constexpr const char* kEpisodeSeedKey = "episode_metadata/episode_seed";
inline constexpr const char* kIntrinsicsKey = "episode_metadata/camera_intrinsics";  // fx fy cx cy

// The episode's own seed, from the dataset seed, split name and index within the split, so an
// episode's content does not depend on how many files or episodes surround it. 63 bits, so it
// is stored as a non-negative int64.
uint64_t EpisodeSeed(uint64_t global_seed, const std::string& split, int64_t index);

struct EpisodeStep {
  SceneState state;  // what the step's observation shows
  Action action{};   // applied after the observation; zero motion on a terminal step
  float reward = 0;  // 1 on the step whose observation first has the block in the goal
  bool is_first = false, is_last = false, is_terminal = false;
};

struct Rollout {
  uint64_t seed = 0;
  PolicyKind policy = PolicyKind::kExpert;
  Appearance look;
  std::vector<EpisodeStep> steps;
  bool success = false;  // ended on a terminal step (block in the goal)
};

// Chooses the action for step `step` of the episode whose scene is `scene`; `rng` is the
// episode's generator (after the scene was sampled from it).
using ActionChooser = std::function<Action(const Scene& scene, int step, Rng& rng)>;

// Simulates one episode under `choose`: at most `max_steps` steps; the episode ends at the first
// step whose state has the block in the goal (reward 1, is_last = is_terminal = 1, no action
// chosen), or after `max_steps` steps (is_last = 1, is_terminal = 0). Recorded actions are the
// clamped ones StepScene applies. Rollout::policy is left as kExpert. The goal is drawn from
// `goals` (SampleScene).
Rollout RollOutWith(uint64_t episode_seed, int max_steps, LookVariation look,
                    const ActionChooser& choose, const GoalRegion& goals = {});

// Simulates one episode under a scripted policy (no rendering).
Rollout RollOut(uint64_t episode_seed, PolicyKind policy, int max_steps,
                LookVariation look = LookVariation::kVaried, const GoalRegion& goals = {});

// One step's images as the dataset stores them.
struct EncodedFrame {
  std::string jpeg, depth_png, labels_png;
};
// Renders the scene at size x size and encodes it (deterministic bytes).
EncodedFrame RenderEncodedFrame(const Scene& scene, int size);

// Renders every step at size x size and serializes the tf.train.Example (deterministic bytes).
std::string EncodeEpisode(const Rollout& rollout, int size);
// The tf.train.Example of an episode whose frames are already encoded (one per step), with
// `policy_id` as its episode_metadata/policy_id.
std::string EncodeEpisode(const Rollout& rollout, const std::vector<EncodedFrame>& frames, int size,
                          const std::string& policy_id);

}  // namespace wm::tabletop

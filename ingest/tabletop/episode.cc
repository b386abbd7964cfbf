#include "ingest/tabletop/episode.h"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "ingest/rlds/example.h"
#include "ingest/tabletop/render.h"

namespace wm::tabletop {
namespace {

uint64_t HashSplitName(const std::string& split) {
  uint64_t h = 0xcbf29ce484222325ULL;  // FNV-1a
  for (unsigned char c : split) h = (h ^ c) * 0x100000001b3ULL;
  return h;
}

std::string Encode(const std::string& ext, const cv::Mat& image, const std::vector<int>& params) {
  std::vector<uint8_t> bytes;
  if (!cv::imencode(ext, image, bytes, params)) {
    throw Error("OpenCV could not encode a " + ext + " image", {.key = "steps/observation"});
  }
  return {bytes.begin(), bytes.end()};
}

EncodedFrame EncodeFrame(Frame& f) {
  const std::vector<int> png = {cv::IMWRITE_PNG_COMPRESSION, 3};
  cv::Mat rgb(f.size, f.size, CV_8UC3, f.rgb.data()), bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);  // imencode expects BGR
  return {Encode(".jpg", bgr, {cv::IMWRITE_JPEG_QUALITY, 95}),
          Encode(".png", cv::Mat(f.size, f.size, CV_16UC1, f.depth_mm.data()), png),
          Encode(".png", cv::Mat(f.size, f.size, CV_8UC1, f.labels.data()), png)};
}

}  // namespace

uint64_t EpisodeSeed(uint64_t global_seed, const std::string& split, int64_t index) {
  const uint64_t h = MixBits(MixBits(global_seed) ^ HashSplitName(split));
  return MixBits(h ^ static_cast<uint64_t>(index)) >> 1;
}

Rollout RollOutWith(uint64_t episode_seed, int max_steps, LookVariation look,
                    const ActionChooser& choose, const GoalRegion& goals) {
  Check(max_steps >= 1, "max_steps must be at least 1", {.key = "--max-steps"});
  Rng rng(episode_seed);
  Scene scene = SampleScene(rng, look, goals);
  Rollout out{episode_seed, PolicyKind::kExpert, scene.look, {}, false};
  for (int t = 0; t < max_steps; ++t) {
    EpisodeStep step;
    step.state = scene.state;
    step.is_first = t == 0;
    if (BlockInGoal(scene.state)) {
      step.reward = 1;
      step.is_last = step.is_terminal = true;
      step.action[6] = static_cast<float>(scene.state.gripper);  // hold still
      out.steps.push_back(step);
      out.success = true;
      break;
    }
    step.action = ClampAction(choose(scene, t, rng));
    step.is_last = t == max_steps - 1;
    out.steps.push_back(step);
    StepScene(scene.state, step.action);
  }
  return out;
}

Rollout RollOut(uint64_t episode_seed, PolicyKind policy_kind, int max_steps, LookVariation look,
                const GoalRegion& goals) {
  std::unique_ptr<Policy> policy;  // made from the first state (wrong_goal needs it)
  Rollout out = RollOutWith(
      episode_seed, max_steps, look,
      [&](const Scene& scene, int, Rng& rng) {
        if (!policy) policy = MakePolicy(policy_kind, scene.state);
        return policy->Act(scene.state, rng);
      },
      goals);
  out.policy = policy_kind;
  return out;
}

EncodedFrame RenderEncodedFrame(const Scene& scene, int size) {
  Frame frame = RenderFrame(scene, size);
  return EncodeFrame(frame);
}

std::string EncodeEpisode(const Rollout& rollout, int size) {
  std::vector<EncodedFrame> frames;
  frames.reserve(rollout.steps.size());
  for (const EpisodeStep& step : rollout.steps) {
    frames.push_back(RenderEncodedFrame({step.state, rollout.look}, size));
  }
  return EncodeEpisode(rollout, frames, size, PolicyName(rollout.policy));
}

std::string EncodeEpisode(const Rollout& rollout, const std::vector<EncodedFrame>& frames, int size,
                          const std::string& policy_id) {
  Check(frames.size() == rollout.steps.size(), "one encoded frame per step is needed");
  std::vector<std::string> images, depths, labels, instructions;
  std::vector<float> actions, rewards, discounts;
  std::vector<int64_t> is_first, is_last, is_terminal;
  for (size_t i = 0; i < rollout.steps.size(); ++i) {
    const EpisodeStep& step = rollout.steps[i];
    images.push_back(frames[i].jpeg);
    depths.push_back(frames[i].depth_png);
    labels.push_back(frames[i].labels_png);
    instructions.push_back(rollout.look.instruction);
    actions.insert(actions.end(), step.action.begin(), step.action.end());
    rewards.push_back(step.reward);
    discounts.push_back(1.0f);
    is_first.push_back(step.is_first);
    is_last.push_back(step.is_last);
    is_terminal.push_back(step.is_terminal);
  }
  const CameraIntrinsics k = IntrinsicsForSize(size);
  rlds::ExampleBuilder b;
  b.AddBytes(kImageKey, images);
  b.AddBytes(kDepthKey, depths);
  b.AddBytes(kSegmentationKey, labels);
  b.AddFloats(kActionKey, actions);
  b.AddFloats(kRewardKey, rewards);
  b.AddFloats(kDiscountKey, discounts);
  b.AddInt64s(kIsFirstKey, is_first);
  b.AddInt64s(kIsLastKey, is_last);
  b.AddInt64s(kIsTerminalKey, is_terminal);
  b.AddBytes(kInstructionKey, instructions);
  b.AddBytes(kPolicyIdKey, {policy_id});
  b.AddInt64s(kEpisodeSeedKey, {static_cast<int64_t>(rollout.seed)});
  b.AddFloats(kIntrinsicsKey, {k.fx, k.fy, k.cx, k.cy});
  return b.Serialize();
}

}  // namespace wm::tabletop

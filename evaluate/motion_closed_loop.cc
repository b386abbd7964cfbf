// The motion model in closed loop (wm-eval --policy with a motion checkpoint and
// --success-model): each imagined frame is the model's next under the policy's action, and
// the success classifier's P(success | frame) is the step's success score (docs/reports.md,
// "Policy evaluation in the world model").
#include <memory>

#include "evaluate/closed_loop.h"
#include "motion/motion_model.h"
#include "success/success_model.h"

namespace wm::evaluate {
namespace {

class MotionWorld : public ImaginedWorld {
 public:
  MotionWorld(const motion::MotionModel& model, const success::SuccessModel& success,
              const ClosedLoopStart& start)
      : model_(model),
        success_(success),
        rollout_(model.StartRollout(start.first_frame.pixels, 1)),
        size_(start.first_frame.size) {}

  ImaginedStep Next(const std::vector<float>& actions, int64_t t) override {
    const int64_t D = model_.action_dim();
    const std::vector<float> action(actions.begin() + t * D, actions.begin() + (t + 1) * D);
    std::vector<float> next = rollout_->Next(action);
    const float reward = success_.Probabilities(next, 1).at(0);
    return {.frame = {1, size_, std::move(next)}, .reward = reward, .terminal_prob = 0};
  }

 private:
  const motion::MotionModel& model_;
  const success::SuccessModel& success_;
  std::unique_ptr<motion::MotionModel::Rollout> rollout_;
  int size_;
};

}  // namespace

WorldFactory MotionWorlds(const motion::MotionModel& model, const success::SuccessModel& success) {
  return [&model, &success](const ClosedLoopStart& start, int) {
    return std::make_unique<MotionWorld>(model, success, start);
  };
}

}  // namespace wm::evaluate

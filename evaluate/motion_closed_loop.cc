// The motion model in closed loop (wm-eval --policy with a motion checkpoint and
// --success-model): each imagined frame is the model's next under the policy's action, and
// the success classifier's P(success | frame) is the step's success score (ScoredBySuccess;
// docs/reports.md, "Policy evaluation in the world model"). The starts of a batch are the rows
// of one MotionModel::Rollout, scored by one classifier call per step; one episode at a time is
// the same with a batch of one.
#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "core/error.h"
#include "evaluate/closed_loop.h"
#include "motion/motion_model.h"

namespace wm::evaluate {
namespace {

// The motion model's imagination of a batch of starts, a row each, all at the same step; its
// steps carry no success score (ScoredBySuccess adds the classifier's).
class MotionBatch : public ImaginedWorlds {
 public:
  MotionBatch(const motion::MotionModel& model, const std::vector<const ClosedLoopStart*>& starts)
      : model_(model),
        rollout_(model.StartRollout(FirstFrames(starts), static_cast<int64_t>(starts.size()))),
        size_(static_cast<int>(model.image_size())),
        step_actions_(starts.size() * static_cast<size_t>(model.action_dim()), 0.f) {}

  std::vector<ImaginedStep> Next(const std::vector<size_t>& rows,
                                 const std::vector<const std::vector<float>*>& actions,
                                 int64_t t) override {
    const auto D = static_cast<size_t>(model_.action_dim());
    for (size_t k = 0; k < rows.size(); ++k) {
      Check(actions[k]->size() == static_cast<size_t>(t + 1) * D,
            "closed loop: expected the actions of steps 0.." + std::to_string(t));
      std::copy(actions[k]->end() - D, actions[k]->end(), step_actions_.begin() + rows[k] * D);
    }
    const std::vector<float> all = rollout_->Next(step_actions_);  // [batch, 3, S, S]
    const size_t frame = static_cast<size_t>(3) * size_ * size_;
    std::vector<ImaginedStep> out;  // only the running rows
    for (size_t row : rows) {
      out.push_back(
          {.frame = {1, size_, {all.begin() + row * frame, all.begin() + (row + 1) * frame}}});
    }
    return out;
  }

 private:
  static std::vector<float> FirstFrames(const std::vector<const ClosedLoopStart*>& starts) {
    std::vector<float> first;  // [batch, 3, S, S]
    for (const ClosedLoopStart* s : starts) {
      first.insert(first.end(), s->first_frame.pixels.begin(), s->first_frame.pixels.end());
    }
    return first;
  }

  const motion::MotionModel& model_;
  std::unique_ptr<motion::MotionModel::Rollout> rollout_;
  const int size_;
  // [batch, D]: each row's newest action. A row that has ended repeats its last one: rows are
  // independent (MotionModel), and its frames go unused.
  std::vector<float> step_actions_;
};

// One start as a batch of one.
class MotionWorld : public ImaginedWorld {
 public:
  explicit MotionWorld(std::unique_ptr<ImaginedWorlds> batch) : batch_(std::move(batch)) {}

  ImaginedStep Next(const std::vector<float>& actions, int64_t t) override {
    return batch_->Next({0}, {&actions}, t).front();
  }

 private:
  std::unique_ptr<ImaginedWorlds> batch_;
};

}  // namespace

WorldFactory MotionWorlds(const motion::MotionModel& model, const success::SuccessModel& success) {
  return [batches = MotionWorldBatches(model, success)](const ClosedLoopStart& start, int) {
    return std::make_unique<MotionWorld>(batches({&start}, 0));
  };
}

WorldsFactory MotionWorldBatches(const motion::MotionModel& model,
                                 const success::SuccessModel& success) {
  return ScoredBySuccess(
      [&model](const std::vector<const ClosedLoopStart*>& starts,
               int) -> std::unique_ptr<ImaginedWorlds> {
        return std::make_unique<MotionBatch>(model, starts);
      },
      success);
}

}  // namespace wm::evaluate

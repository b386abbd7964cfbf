// ScoredBySuccess: any imagined worlds' steps scored by a success classifier instead of the
// model's own heads (evaluate/closed_loop.h).
#include <memory>
#include <utility>
#include <vector>

#include "evaluate/closed_loop.h"
#include "success/success_model.h"

namespace wm::evaluate {
namespace {

class SuccessScoredWorlds : public ImaginedWorlds {
 public:
  SuccessScoredWorlds(std::unique_ptr<ImaginedWorlds> worlds, const success::SuccessModel& success)
      : worlds_(std::move(worlds)), success_(success) {}

  std::vector<ImaginedStep> Next(const std::vector<size_t>& rows,
                                 const std::vector<const std::vector<float>*>& actions,
                                 int64_t t) override {
    std::vector<ImaginedStep> steps = worlds_->Next(rows, actions, t);
    std::vector<float> frames;  // [rows, 3, S, S]: one classifier call for the step
    for (const ImaginedStep& step : steps) {
      frames.insert(frames.end(), step.frame.pixels.begin(), step.frame.pixels.end());
    }
    const std::vector<float> p = success_.Probabilities(frames, static_cast<int64_t>(steps.size()));
    for (size_t k = 0; k < steps.size(); ++k) {
      steps[k].reward = p[k];
      steps[k].terminal_prob = 0;
    }
    return steps;
  }

 private:
  std::unique_ptr<ImaginedWorlds> worlds_;
  const success::SuccessModel& success_;
};

}  // namespace

WorldsFactory ScoredBySuccess(WorldsFactory worlds, const success::SuccessModel& success) {
  return [worlds = std::move(worlds), &success](const std::vector<const ClosedLoopStart*>& starts,
                                                int rollout) -> std::unique_ptr<ImaginedWorlds> {
    return std::make_unique<SuccessScoredWorlds>(worlds(starts, rollout), success);
  };
}

}  // namespace wm::evaluate

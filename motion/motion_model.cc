#include "motion/motion_model.h"

#include <torch/torch.h>

#include "core/error.h"
#include "core/paths.h"
#include "core/tensor_archive.h"
#include "motion/motion_net.h"
#include "trainkit/action_norm.h"
#include "trainkit/checkpoint_kind.h"
#include "trainkit/module_archive.h"
#include "trainkit/torch_runtime.h"

namespace wm::motion {

struct MotionModel::State {
  MotionConfig config;
  std::unique_ptr<MotionNet> net;
  trainkit::ActionNorm norm;
  torch::Device device{torch::kCPU};
  int64_t step = 0;
  std::string file;
};

MotionModel::MotionModel() : state_(std::make_unique<State>()) {}
MotionModel::~MotionModel() = default;

bool MotionModel::IsMotionCheckpoint(const std::string& path) {
  return trainkit::IsCheckpointOfKind(path, "motion");
}

std::unique_ptr<MotionModel> MotionModel::Load(const std::string& path, const std::string& device,
                                               int threads) {
  trainkit::CheckDevice(device);
  if (threads > 0) torch::set_num_threads(threads);
  std::unique_ptr<MotionModel> model(new MotionModel());
  State& s = *model->state_;
  s.file = CheckpointFileIn(path);
  trainkit::LoadCheckpointOfKind(
      s.file, "motion", "not a motion model checkpoint (wm-motion train writes those)",
      [&](const TensorArchiveReader& reader, const nlohmann::json& meta) {
        s.config = ConfigFromJson(meta.at("config"));
        ValidateConfig(s.config, s.file);
        const nlohmann::json& norms = meta.at("action_norms");
        Check(norms.size() == 1, "expected the statistics of one training dataset",
              {.key = "action_norms"});
        s.norm = trainkit::ActionNorm::FromJson(norms.begin().value());
        const auto action_dim = meta.at("action_dim").get<int64_t>();
        Check(s.norm.dim() == action_dim,
              "action statistics have " + std::to_string(s.norm.dim()) + " values, the model " +
                  std::to_string(action_dim),
              {.key = "action_norms"});
        s.step = meta.at("step").get<int64_t>();
        s.net = std::make_unique<MotionNet>(s.config.model, action_dim);
        trainkit::LoadModule(reader, "model/", s.net->module());
      });
  s.device = torch::Device(device);
  s.net->module().to(s.device);
  s.net->module().eval();
  return model;
}

const MotionConfig& MotionModel::config() const { return state_->config; }
int64_t MotionModel::image_size() const { return state_->config.model.image_size; }
int64_t MotionModel::action_dim() const { return state_->net->action_dim(); }
int64_t MotionModel::step() const { return state_->step; }
const std::string& MotionModel::checkpoint_file() const { return state_->file; }

namespace {

// Throws wm::Error naming `file` unless `values` holds `count` values, `shape` in words.
void CheckSize(const std::vector<float>& values, int64_t count, const std::string& what,
               const std::string& shape, const std::string& file) {
  Check(static_cast<int64_t>(values.size()) == count,
        what + ": expected " + shape + " values (" + std::to_string(count) + "), got " +
            std::to_string(values.size()),
        {.file = file});
}

std::string FramesShape(int64_t batch, int64_t size) {
  return std::to_string(batch) + " x 3 x " + std::to_string(size) + " x " + std::to_string(size);
}

std::vector<float> ToVector(const torch::Tensor& t) {
  const torch::Tensor cpu = t.to(torch::kCPU).contiguous();
  return {cpu.data_ptr<float>(), cpu.data_ptr<float>() + cpu.numel()};
}

}  // namespace

struct MotionModel::Rollout::State {
  MotionModel::State& model;
  int64_t batch;
  motion::Rollout rollout;
};

MotionModel::Rollout::Rollout(std::unique_ptr<State> state) : state_(std::move(state)) {}
MotionModel::Rollout::~Rollout() = default;

std::unique_ptr<MotionModel::Rollout> MotionModel::StartRollout(const std::vector<float>& first,
                                                                int64_t batch) const {
  State& s = *state_;  // the net's forward is not const
  const int64_t S = image_size();
  CheckSize(first, batch * 3 * S * S, "first frames", FramesShape(batch, S), s.file);
  torch::NoGradGuard no_grad;
  const torch::Tensor frames =
      torch::from_blob(const_cast<float*>(first.data()), {batch, 3, S, S}).to(s.device);
  return std::unique_ptr<Rollout>(new Rollout(std::make_unique<Rollout::State>(
      Rollout::State{s, batch, motion::Rollout(*s.net, frames.clone())})));
}

std::vector<float> MotionModel::Rollout::Next(const std::vector<float>& raw_actions) {
  State& r = *state_;
  const int64_t D = r.model.net->action_dim();
  CheckSize(raw_actions, r.batch * D, "actions",
            std::to_string(r.batch) + " x " + std::to_string(D), r.model.file);
  std::vector<float> normed(raw_actions.size());
  r.model.norm.Apply(raw_actions.data(), normed.data(), r.batch);
  torch::NoGradGuard no_grad;
  return ToVector(r.rollout.Next(torch::from_blob(normed.data(), {r.batch, D}).to(r.model.device)));
}

std::vector<float> MotionModel::Imagine(const std::vector<float>& first,
                                        const std::vector<float>& raw_actions, int64_t batch,
                                        int64_t horizon) const {
  State& s = *state_;  // the net's forward is not const
  const int64_t S = image_size(), D = action_dim();
  CheckSize(first, batch * 3 * S * S, "first frames", FramesShape(batch, S), s.file);
  Check(static_cast<int64_t>(raw_actions.size()) == batch * horizon * D,
        "actions: the model takes " + std::to_string(D) + " values per step; expected " +
            std::to_string(batch * horizon * D) + " values, got " +
            std::to_string(raw_actions.size()),
        {.file = s.file});
  std::vector<float> normed(raw_actions.size());
  s.norm.Apply(raw_actions.data(), normed.data(), batch * horizon);
  return ToVector(motion::Imagine(
      *s.net, torch::from_blob(const_cast<float*>(first.data()), {batch, 3, S, S}).to(s.device),
      torch::from_blob(normed.data(), {batch, horizon, D}).to(s.device)));
}

}  // namespace wm::motion

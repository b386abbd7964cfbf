#include "motion/motion_model.h"

#include <torch/torch.h>

#include "core/error.h"
#include "core/paths.h"
#include "core/tensor_archive.h"
#include "motion/warp_net.h"
#include "trainkit/action_norm.h"
#include "trainkit/checkpoint_kind.h"
#include "trainkit/module_archive.h"
#include "trainkit/torch_runtime.h"

namespace wm::motion {

struct MotionModel::State {
  MotionConfig config;
  WarpNet net{nullptr};
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
        s.net = WarpNet(s.config.model, action_dim);
        trainkit::LoadModule(reader, "model/", *s.net);
      });
  s.device = torch::Device(device);
  s.net->to(s.device);
  s.net->eval();
  return model;
}

const MotionConfig& MotionModel::config() const { return state_->config; }
int64_t MotionModel::image_size() const { return state_->config.model.image_size; }
int64_t MotionModel::action_dim() const { return state_->net->action_dim(); }
int64_t MotionModel::step() const { return state_->step; }
const std::string& MotionModel::checkpoint_file() const { return state_->file; }

namespace {

// Throws wm::Error naming `file` unless `values` holds `count` x `what`'s shape.
void CheckSize(const std::vector<float>& values, int64_t count, const std::string& what,
               const std::string& shape, const std::string& file) {
  Check(static_cast<int64_t>(values.size()) == count,
        what + ": expected " + shape + " values (" + std::to_string(count) + "), got " +
            std::to_string(values.size()),
        {.file = file});
}

}  // namespace

std::vector<float> MotionModel::ImagineNext(const std::vector<float>& current,
                                            const std::vector<float>& previous,
                                            const std::vector<float>& raw_actions,
                                            int64_t batch) const {
  State& s = *state_;  // the net's forward is not const
  const int64_t S = image_size(), D = action_dim();
  const std::string frames =
      std::to_string(batch) + " x 3 x " + std::to_string(S) + " x " + std::to_string(S);
  CheckSize(current, batch * 3 * S * S, "current frames", frames, s.file);
  CheckSize(previous, batch * 3 * S * S, "previous frames", frames, s.file);
  CheckSize(raw_actions, batch * D, "actions", std::to_string(batch) + " x " + std::to_string(D),
            s.file);
  std::vector<float> normed(raw_actions.size());
  s.norm.Apply(raw_actions.data(), normed.data(), batch);
  const auto planar = [&](const std::vector<float>& v) {
    return torch::from_blob(const_cast<float*>(v.data()), {batch, 3, S, S}).to(s.device);
  };
  torch::NoGradGuard no_grad;
  const torch::Tensor next = s.net
                                 ->forward(planar(current), planar(previous),
                                           torch::from_blob(normed.data(), {batch, D}).to(s.device))
                                 .next.clamp(-1, 1)
                                 .to(torch::kCPU)
                                 .contiguous();
  return {next.data_ptr<float>(), next.data_ptr<float>() + next.numel()};
}

std::vector<float> MotionModel::Imagine(const std::vector<float>& first,
                                        const std::vector<float>& raw_actions, int64_t batch,
                                        int64_t horizon) const {
  State& s = *state_;  // the net's forward is not const
  const int64_t S = image_size(), D = action_dim();
  Check(static_cast<int64_t>(first.size()) == batch * 3 * S * S,
        "first frames: expected " + std::to_string(batch) + " x 3 x " + std::to_string(S) + " x " +
            std::to_string(S) + " values, got " + std::to_string(first.size()),
        {.file = s.file});
  Check(static_cast<int64_t>(raw_actions.size()) == batch * horizon * D,
        "actions: the model takes " + std::to_string(D) + " values per step; expected " +
            std::to_string(batch * horizon * D) + " values, got " +
            std::to_string(raw_actions.size()),
        {.file = s.file});
  std::vector<float> normed(raw_actions.size());
  s.norm.Apply(raw_actions.data(), normed.data(), batch * horizon);
  const torch::Tensor frames = motion::Imagine(
      s.net, torch::from_blob(const_cast<float*>(first.data()), {batch, 3, S, S}).to(s.device),
      torch::from_blob(normed.data(), {batch, horizon, D}).to(s.device));
  const torch::Tensor out = frames.to(torch::kCPU).contiguous();
  return {out.data_ptr<float>(), out.data_ptr<float>() + out.numel()};
}

}  // namespace wm::motion

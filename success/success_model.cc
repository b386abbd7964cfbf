#include "success/success_model.h"

#include <torch/torch.h>

#include <filesystem>

#include "core/error.h"
#include "core/paths.h"
#include "core/tensor_archive.h"
#include "success/success_net.h"
#include "trainkit/checkpoint_kind.h"
#include "trainkit/module_archive.h"
#include "trainkit/torch_runtime.h"

namespace wm::success {

struct SuccessModel::State {
  SuccessConfig config;
  SuccessNet net{nullptr};
  torch::Device device{torch::kCPU};
  int64_t step = 0;
  std::string file;
};

SuccessModel::SuccessModel() : state_(std::make_unique<State>()) {}
SuccessModel::~SuccessModel() = default;

bool SuccessModel::IsSuccessCheckpoint(const std::string& path) {
  return trainkit::IsCheckpointOfKind(path, "success");
}

std::unique_ptr<SuccessModel> SuccessModel::Load(const std::string& path, const std::string& device,
                                                 int threads) {
  trainkit::CheckDevice(device);
  if (threads > 0) torch::set_num_threads(threads);
  std::unique_ptr<SuccessModel> model(new SuccessModel());
  State& s = *model->state_;
  s.file = CheckpointFileIn(path);
  Check(std::filesystem::is_regular_file(s.file),
        "no success classifier checkpoint here (wm-success train writes RUN_DIR/checkpoint.wmt)",
        {.file = s.file});
  trainkit::LoadCheckpointOfKind(
      s.file, "success", "not a success classifier checkpoint (wm-success train writes those)",
      [&](const TensorArchiveReader& reader, const nlohmann::json& meta) {
        s.config = ConfigFromJson(meta.at("config"));
        ValidateConfig(s.config, s.file);
        s.step = meta.at("step").get<int64_t>();
        s.net = SuccessNet(s.config.model);
        trainkit::LoadModule(reader, "model/", *s.net);
      });
  s.device = torch::Device(device);
  s.net->to(s.device);
  s.net->eval();
  return model;
}

const SuccessConfig& SuccessModel::config() const { return state_->config; }
int64_t SuccessModel::image_size() const { return state_->config.model.image_size; }
int64_t SuccessModel::step() const { return state_->step; }
const std::string& SuccessModel::checkpoint_file() const { return state_->file; }

std::vector<float> SuccessModel::Probabilities(const std::vector<float>& frames,
                                               int64_t count) const {
  State& s = *state_;  // the net's forward is not const
  const int64_t S = image_size();
  Check(static_cast<int64_t>(frames.size()) == count * 3 * S * S,
        "frames: expected " + std::to_string(count) + " x 3 x " + std::to_string(S) + " x " +
            std::to_string(S) + " values, got " + std::to_string(frames.size()),
        {.file = s.file});
  torch::NoGradGuard no_grad;
  const torch::Tensor p =
      torch::sigmoid(
          s.net->forward(
              torch::from_blob(const_cast<float*>(frames.data()), {count, 3, S, S}).to(s.device)))
          .to(torch::kCPU)
          .contiguous();
  return {p.data_ptr<float>(), p.data_ptr<float>() + p.numel()};
}

}  // namespace wm::success

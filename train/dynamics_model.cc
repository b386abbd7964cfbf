#include "train/dynamics_model.h"

#include <torch/torch.h>

#include "core/error.h"
#include "core/log.h"
#include "train/batch.h"
#include "train/checkpoint.h"
#include "train/imagine_step.h"
#include "train/rolling_imagination.h"
#include "train/segment_sampler.h"
#include "train/world_model.h"

namespace wm::train {

struct DynamicsModel::State {
  DynamicsConfig config;
  WorldModel model{nullptr};  // mutable use through const API: inference has no side effects
  ActionNorm norm;
  torch::Device device{torch::kCPU};
  int64_t step = 0;
  std::string file;  // the loaded checkpoint.wmt

  int64_t N() const { return config.model.tokens_per_frame(); }

  // Refuses `tokens` with a code outside [0, num_codes), naming them as `what`.
  void CheckCodes(const torch::Tensor& tokens, const std::string& what) const {
    Check(
        tokens.min().item<int64_t>() >= 0 && tokens.max().item<int64_t>() < config.model.num_codes,
        what + " token outside [0, num_codes)");
  }

  // Raw actions [rows, A] of the action dataset as the model's normalised, zero-padded
  // [rows, action_dim] on the model's device.
  torch::Tensor NormalisedActions(const std::vector<float>& raw, int64_t rows) const {
    const int64_t A = norm.dim(), D = config.model.action_dim;
    Check(static_cast<int64_t>(raw.size()) == rows * A,
          std::to_string(raw.size()) + " action values, expected rows x " + std::to_string(A));
    std::vector<float> normed(static_cast<size_t>(rows * D), 0.f);
    norm.Apply(raw.data(), normed.data(), rows, D);
    return torch::tensor(normed).view({rows, D}).to(device);
  }

  // The context's last `keep` frames as tensors: tokens [B, Tk, N], normalised actions
  // [B, Tk, D] (a narrower action dataset's zero-padded, as in training), z [B, Tk, Z]
  // (undefined without policy conditioning).
  void Tensors(const FrameContext& c, int64_t keep, torch::Tensor& tokens, torch::Tensor& actions,
               torch::Tensor& z) {
    const int64_t B = c.batch, T = c.frames, n = N();
    Check(B > 0 && T > 0, "empty context");
    Check(static_cast<int64_t>(c.tokens.size()) == B * T * n,
          "context has " + std::to_string(c.tokens.size()) + " tokens, expected batch x frames x " +
              std::to_string(n));
    const int64_t A = norm.dim(), D = config.model.action_dim;
    const auto got = static_cast<int64_t>(c.actions.size());
    Check(got == B * T * A, got % (B * T) == 0
                                ? "context has " + std::to_string(got / (B * T)) +
                                      "-dim actions, the model takes " + std::to_string(A) +
                                      "-dim ones"
                                : "context has " + std::to_string(got) +
                                      " action values, expected batch x frames x " +
                                      std::to_string(A) + " = " + std::to_string(B * T * A));
    const int64_t first = std::max<int64_t>(0, T - keep);
    tokens = torch::tensor(c.tokens, torch::kInt64).view({B, T, n}).slice(1, first, T);
    CheckCodes(tokens, "context");
    actions = NormalisedActions(c.actions, B * T).view({B, T, D}).slice(1, first, T);
    tokens = tokens.contiguous().to(device);
    actions = actions.contiguous().to(device);
    if (!model->policy) {
      Check(c.policy_z.empty(), "policy_z given but the model has no policy conditioning");
      z = torch::Tensor();
      return;
    }
    const int64_t Z = int64_t{config.policy.categories} * config.policy.classes;
    if (c.policy_z.empty()) {
      z = model->DynamicsZ(tokens, actions);  // [B, Tk, Z]
    } else {
      Check(static_cast<int64_t>(c.policy_z.size()) == B * Z,
            "policy_z must have batch x " + std::to_string(Z) + " values");
      z = torch::tensor(c.policy_z).view({B, 1, Z}).expand({B, tokens.size(1), Z}).to(device);
    }
  }
};

DynamicsModel::DynamicsModel() : state_(std::make_unique<State>()) {}
DynamicsModel::~DynamicsModel() = default;

std::unique_ptr<DynamicsModel> DynamicsModel::Load(const std::string& path,
                                                   const std::string& device,
                                                   const std::string& action_dataset, int threads) {
  const std::string file = CheckpointFileIn(path);
  std::unique_ptr<DynamicsModel> m(new DynamicsModel());
  State& s = *m->state_;
  s.file = file;
  if (threads > 0) torch::set_num_threads(threads);
  CheckpointMeta meta = ReadCheckpointMeta(file);
  s.config = ConfigFromJson(meta.config);
  ValidateConfig(s.config, file);
  s.step = meta.step;
  if (meta.reward_target != kRewardTargetFrame) {
    LogWarn(file +
            ": trained before the reward head predicted each frame's own step, so its "
            "rewards and terminal flags are one step late and never saw a final reward; "
            "retrain it for value metrics (its frames are unaffected)");
  }
  s.device = torch::Device(device);
  Check(!s.device.is_cuda() || torch::cuda::is_available(),
        "device " + device + " requested but CUDA is not available");
  Check(meta.action_norms.is_object() && !meta.action_norms.empty(),
        "checkpoint has no action statistics", {.file = file, .key = "meta.action_norms"});
  const std::string name =
      action_dataset.empty() ? meta.action_norms.begin().key() : action_dataset;
  Check(meta.action_norms.contains(name),
        "model was not trained on dataset '" + name + "' (no action statistics)", {.file = file});
  s.norm = ActionNorm::FromJson(meta.action_norms[name]);
  Check(s.norm.dim() <= s.config.model.action_dim,
        "dataset '" + name + "' has " + std::to_string(s.norm.dim()) +
            " action values, the model takes " + std::to_string(s.config.model.action_dim),
        {.file = file, .key = "meta.action_norms"});
  s.model = WorldModel(s.config);
  LoadCheckpoint(file, s.model, nullptr);
  s.model->to(s.device);
  s.model->eval();
  return m;
}

const DynamicsConfig& DynamicsModel::config() const { return state_->config; }
int64_t DynamicsModel::tokens_per_frame() const { return state_->N(); }
int64_t DynamicsModel::action_dim() const { return state_->norm.dim(); }
bool DynamicsModel::HasActionDataset(const std::string& path, const std::string& dataset) {
  const CheckpointMeta meta = ReadCheckpointMeta(CheckpointFileIn(path));
  return meta.action_norms.is_object() && meta.action_norms.contains(dataset);
}
int64_t DynamicsModel::step() const { return state_->step; }
const std::string& DynamicsModel::checkpoint_file() const { return state_->file; }
int64_t DynamicsModel::max_context_frames() const {
  return state_->config.model.context_frames - 1;
}

double DynamicsModel::DecodeTemperature(double requested) const {
  return requested >= 0 ? requested : state_->config.model.decode_temperature;
}

namespace {

// context.row_seeds, or MixSeed(seed, row) for each row when it has none.
std::vector<uint64_t> RowSeeds(const FrameContext& context, uint64_t seed) {
  std::vector<uint64_t> row_seeds = context.row_seeds;
  if (row_seeds.empty()) {
    for (int64_t b = 0; b < context.batch; ++b) row_seeds.push_back(MixSeed(seed, b));
  }
  Check(static_cast<int64_t>(row_seeds.size()) == context.batch,
        "row_seeds must have one seed per row (" + std::to_string(context.batch) + ")");
  return row_seeds;
}

template <typename T>
std::vector<T> HostVector(const torch::Tensor& x) {
  const torch::Tensor c = x.to(torch::kCPU).contiguous();
  return std::vector<T>(c.data_ptr<T>(), c.data_ptr<T>() + c.numel());
}

// `context` with `frame` ([batch, N]) appended to every row, each row's new action zero.
FrameContext Extended(const FrameContext& context, const std::vector<int64_t>& frame,
                      int64_t action_dim) {
  FrameContext c = context;
  c.frames += 1;
  c.tokens.clear(), c.actions.clear();
  const auto n = static_cast<int64_t>(frame.size()) / context.batch, T = context.frames;
  for (int64_t b = 0; b < context.batch; ++b) {
    auto tokens = context.tokens.begin() + b * T * n;
    auto actions = context.actions.begin() + b * T * action_dim;
    c.tokens.insert(c.tokens.end(), tokens, tokens + T * n);
    c.tokens.insert(c.tokens.end(), frame.begin() + b * n, frame.begin() + (b + 1) * n);
    c.actions.insert(c.actions.end(), actions, actions + T * action_dim);
    c.actions.insert(c.actions.end(), action_dim, 0.f);
  }
  return c;
}

}  // namespace

std::vector<int64_t> DynamicsModel::PredictNextFrame(const FrameContext& context, uint64_t seed,
                                                     int steps, double temperature,
                                                     std::vector<float>* token_entropy) const {
  torch::NoGradGuard no_grad;
  State& s = *state_;  // unique_ptr: const API, non-const state
  torch::Tensor tokens, actions, z, entropy;
  s.Tensors(context, max_context_frames(), tokens, actions, z);
  const int n_steps = steps > 0 ? steps : s.config.model.decode_steps;
  torch::Tensor next =
      DecodeNextFrame(s.model, tokens, actions, z, n_steps, DecodeTemperature(temperature),
                      RowSeeds(context, seed), token_entropy ? &entropy : nullptr);
  if (token_entropy) *token_entropy = HostVector<float>(entropy.contiguous());  // [B, N]
  return HostVector<int64_t>(next);                                             // [B, N]
}

ImaginedSteps DynamicsModel::ImagineStep(const FrameContext& context, uint64_t seed, int steps,
                                         double temperature) const {
  torch::NoGradGuard no_grad;
  State& s = *state_;  // unique_ptr: const API, non-const state
  Check(context.frames <= max_context_frames(),
        "ImagineStep takes at most " + std::to_string(max_context_frames()) + " context frames");
  const OneDnnLinearScope onednn;
  torch::Tensor tokens, actions, z;
  s.Tensors(context, context.frames, tokens, actions, z);
  CachedWindow window(s.model, tokens, actions, z);
  ImaginedSteps out;
  out.tokens = HostVector<int64_t>(
      window.DecodeNext(steps > 0 ? steps : s.config.model.decode_steps,
                        DecodeTemperature(temperature), RowSeeds(context, seed)));
  // The reward of the step to the new frame, seen from the window extended by it (the policy
  // prior's z included), as PredictRewards sees it.
  s.Tensors(Extended(context, out.tokens, action_dim()), context.frames + 1, tokens, actions, z);
  const DynamicsOutput r = window.StepReward(tokens, actions, z);
  out.reward = HostVector<float>(r.reward.to(torch::kFloat));
  out.terminal_prob = HostVector<float>(torch::sigmoid(r.terminal_logit).to(torch::kFloat));
  return out;
}

bool DynamicsModel::CanRoll() const { return state_->model->dynamics->can_roll(); }

struct RollingImagination::State {
  const DynamicsModel::State* owner = nullptr;  // the model it imagines with, which outlives it
  std::unique_ptr<RollingWindow> window;
};

RollingImagination::RollingImagination() : state_(std::make_unique<State>()) {}
RollingImagination::~RollingImagination() = default;

std::unique_ptr<RollingImagination> DynamicsModel::StartRolling(
    const std::vector<int64_t>& first_frames, int64_t batch) const {
  torch::NoGradGuard no_grad;
  State& s = *state_;  // unique_ptr: const API, non-const state
  Check(CanRoll(), s.file +
                       ": rolling imagination needs a next_frame model with "
                       "model.temporal_positions rope (this one: " +
                       s.config.model.objective + ", " + s.config.model.temporal_positions + ")");
  Check(batch > 0 && static_cast<int64_t>(first_frames.size()) == batch * s.N(),
        "StartRolling: first_frames must hold batch x " + std::to_string(s.N()) + " tokens");
  const torch::Tensor first = torch::tensor(first_frames, torch::kInt64).view({batch, s.N()});
  s.CheckCodes(first, "first frame");
  std::unique_ptr<RollingImagination> r(new RollingImagination());
  r->state_->owner = &s;
  // The reward pass's action not yet taken: a raw zero, as ImagineStep's extended window has.
  const torch::Tensor unknown = s.NormalisedActions(std::vector<float>(s.norm.dim(), 0.f), 1);
  r->state_->window = std::make_unique<RollingWindow>(s.model, first.to(s.device), unknown);
  return r;
}

ImaginedSteps RollingImagination::Step(const std::vector<int64_t>& rows,
                                       const std::vector<float>& actions,
                                       const std::vector<uint64_t>& row_seeds, double temperature) {
  torch::NoGradGuard no_grad;
  const OneDnnLinearScope onednn;
  const DynamicsModel::State& s = *state_->owner;
  const auto R = static_cast<int64_t>(rows.size());
  const torch::Tensor row_index = torch::tensor(rows, torch::kInt64).to(s.device);
  DynamicsOutput r;
  const torch::Tensor next = state_->window->Step(
      row_index, s.NormalisedActions(actions, R),
      temperature >= 0 ? temperature : s.config.model.decode_temperature, row_seeds, r);
  ImaginedSteps out;
  out.tokens = HostVector<int64_t>(next);
  out.reward = HostVector<float>(r.reward.to(torch::kFloat));
  out.terminal_prob = HostVector<float>(torch::sigmoid(r.terminal_logit).to(torch::kFloat));
  return out;
}

RewardPrediction DynamicsModel::PredictRewards(const FrameContext& context) const {
  torch::NoGradGuard no_grad;
  State& s = *state_;  // unique_ptr: const API, non-const state
  Check(context.frames >= 1 && context.frames <= s.config.model.context_frames,
        "reward prediction needs 1.." + std::to_string(s.config.model.context_frames) + " frames");
  torch::Tensor tokens, actions, z;
  s.Tensors(context, context.frames, tokens, actions, z);
  DynamicsOutput out = s.model->Dynamics(tokens, actions, z);
  return {HostVector<float>(out.reward.to(torch::kFloat)),  // position j: step j
          HostVector<float>(torch::sigmoid(out.terminal_logit).to(torch::kFloat))};
}

std::vector<float> DynamicsModel::PolicyEmbedding(const FrameContext& context) const {
  torch::NoGradGuard no_grad;
  State& s = *state_;  // unique_ptr: const API, non-const state
  if (!s.model->policy) return {};
  FrameContext c = context;
  c.policy_z.clear();
  torch::Tensor tokens, actions, z;
  s.Tensors(c, s.config.model.context_frames, tokens, actions, z);
  return HostVector<float>(z.select(1, z.size(1) - 1));  // [B, Z]
}

}  // namespace wm::train

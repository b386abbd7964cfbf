#include "train/trainer.h"

#include <ATen/autocast_mode.h>
#include <torch/torch.h>

#include <chrono>
#include <optional>
#include <sstream>

#include "core/error.h"
#include "core/log.h"
#include "core/provenance.h"
#include "train/batch.h"
#include "train/checkpoint.h"
#include "train/distributed.h"
#include "train/init_from.h"
#include "trainkit/adamw.h"
#include "trainkit/module_archive.h"
#include "trainkit/phase_timer.h"
#include "trainkit/run_dir.h"
#include "trainkit/schedule.h"
#include "trainkit/step_log.h"
#include "trainkit/torch_runtime.h"
#include "trainkit/training_loop.h"

namespace wm::train {
namespace {

constexpr const char* kMetrics = "metrics.csv";
constexpr const char* kMetricsHeader =
    "step,loss,token_ce,token_acc,reward_mse,terminal_bce,policy_nll,policy_kl,lr,tokens_per_s,"
    "val_token_ce,val_token_acc";
constexpr uint64_t kValSeedSalt = 0x76616C6964ull;

// bf16 autocast on CUDA for the forward pass (WHALE trains in mixed precision); CPU stays fp32.
class AutocastScope {
 public:
  explicit AutocastScope(bool on) : on_(on) {
    if (!on_) return;
#if TORCH_VERSION_MAJOR > 2 || (TORCH_VERSION_MAJOR == 2 && TORCH_VERSION_MINOR >= 4)
    at::autocast::set_autocast_dtype(at::kCUDA, at::kBFloat16);
    at::autocast::set_autocast_enabled(at::kCUDA, true);
#else
    at::autocast::set_autocast_gpu_dtype(at::kBFloat16);
    at::autocast::set_enabled(true);
#endif
  }
  ~AutocastScope() {
    if (!on_) return;
#if TORCH_VERSION_MAJOR > 2 || (TORCH_VERSION_MAJOR == 2 && TORCH_VERSION_MINOR >= 4)
    at::autocast::set_autocast_enabled(at::kCUDA, false);
#else
    at::autocast::set_enabled(false);
#endif
    at::autocast::clear_cache();
  }

 private:
  bool on_;
};

// Next-frame prediction on fixed validation segments: frame T-1 from clean frames 0..T-2 (one
// pass, the first MaskGIT round for "masked"). Returns {token CE, token accuracy} over frame T-1.
std::pair<double, double> Validate(WorldModel& model, const SegmentSampler& val,
                                   const DynamicsConfig& c, const torch::Device& device) {
  torch::NoGradGuard no_grad;
  const int64_t T = c.model.context_frames, K = c.model.num_codes;
  double ce = 0, acc = 0;
  SegmentData d;
  for (int i = 0; i < c.train.val_batches; ++i) {
    auto refs = val.Draw(c.train.seed ^ kValSeedSalt, i, c.train.batch_size);
    val.Fill(refs, 0, refs.size(), d);
    SegmentBatch b = MakeSegmentBatch(c, d, DrawStepNoise(c, 0, 0, d.batch), 0, 1, device);
    torch::Tensor z = model->DynamicsZ(b.tokens, b.actions);
    torch::Tensor logits =
        model
            ->NextFrameLogits(b.tokens.slice(1, 0, T - 1), b.actions.slice(1, 0, T - 1),
                              z.defined() ? z.slice(1, 0, T - 1) : z)
            .to(torch::kFloat);                        // [B, N, K]
    torch::Tensor target = b.tokens.select(1, T - 1);  // [B, N]
    ce += torch::nn::functional::cross_entropy(logits.reshape({-1, K}), target.reshape({-1}))
              .item<double>();
    acc += (logits.argmax(-1) == target).to(torch::kDouble).mean().item<double>();
  }
  return {ce / c.train.val_batches, acc / c.train.val_batches};
}

void Clip(const std::vector<torch::Tensor>& params, double max_norm) {
  if (max_norm > 0 && !params.empty()) torch::nn::utils::clip_grad_norm_(params, max_norm);
}

// The token datasets must have the config's grid and codebook (the levels per cell come from
// the data, as the action width).
void CheckTokensFit(const SegmentSampler& sampler, const ModelConfig& m) {
  Check(sampler.grid_h() == m.grid_h && sampler.grid_w() == m.grid_w,
        "token data has " + std::to_string(sampler.grid_h()) + "x" +
            std::to_string(sampler.grid_w()) + " tokens per frame, config says " +
            std::to_string(m.grid_h) + "x" + std::to_string(m.grid_w),
        {.key = "model.grid_h"});
  Check(sampler.num_codes() == m.num_codes,
        "token data has " + std::to_string(sampler.num_codes()) + " codes, config says " +
            std::to_string(m.num_codes),
        {.key = "model.num_codes"});
}

// The archive meta of a new run on `sampler`'s data (step 0).
CheckpointMeta NewRunMeta(const DynamicsConfig& cfg, const SegmentSampler& sampler) {
  CheckpointMeta meta;
  meta.config = ConfigToJson(cfg);
  meta.config_hash = ConfigHash(meta.config);
  meta.action_norms = sampler.ActionNorms();
  meta.tokenizer = {
      {"checkpoint_sha256", sampler.DataProvenance()[0].at("tokenizer_checkpoint_sha256")},
      {"num_codes", sampler.num_codes()},
      {"grid_h", sampler.grid_h()},
      {"grid_w", sampler.grid_w()}};
  if (sampler.levels() != 1) meta.tokenizer["levels"] = sampler.levels();
  meta.rng = {{"scheme",
               "counter: mt19937_64(MixSeed(seed, step)) segments, torch CPU generator "
               "noise; no state beyond seed and step"},
              {"seed", cfg.train.seed}};
  return meta;
}

// The model and its optimizer; the parameters split into the dynamics and the policy
// embedding's, which are clipped separately. Parameters under `frozen` prefixes (--freeze) get no
// gradient and stay out of the optimizer, so they keep their bits.
struct Trainee {
  Trainee(const DynamicsConfig& cfg, const torch::Device& device,
          const std::vector<std::string>& frozen)
      : model(cfg) {
    model->to(device);
    std::vector<std::pair<std::string, torch::Tensor>> named;
    for (const auto& item : model->named_parameters()) {
      num_parameters += item.value().numel();
      if (trainkit::IsFrozen(item.key(), frozen)) {
        item.value().set_requires_grad(false);
        continue;
      }
      named.emplace_back(item.key(), item.value());
      (item.key().rfind("policy.", 0) == 0 ? policy_params : dyn_params).push_back(item.value());
      all_params.push_back(item.value());
    }
    const TrainConfig& t = cfg.train;
    adamw = std::make_unique<trainkit::AdamW>(
        named,
        trainkit::AdamWOptions{
            .lr = t.max_lr, .beta1 = t.beta1, .beta2 = t.beta2, .weight_decay = t.weight_decay});
  }
  WorldModel model;
  std::unique_ptr<trainkit::AdamW> adamw;
  std::vector<torch::Tensor> dyn_params, policy_params, all_params;
  int64_t num_parameters = 0;
};

// Loads the checkpoint being resumed into `t` and `meta`; returns its step.
int64_t Resume(const trainkit::RunDir& run, bool writer, const SegmentSampler& sampler, Trainee& t,
               CheckpointMeta& meta) {
  const nlohmann::json expected = trainkit::HashedConfig(meta.config, meta.init_from);
  const CheckpointMeta loaded = LoadCheckpoint(run.checkpoint(), t.model, t.adamw.get(), &expected);
  Check(loaded.reward_target == kRewardTargetFrame,
        "checkpoint trained with the earlier reward alignment (position j predicting step j-1); "
        "resuming would switch its reward target mid-run: start a new run directory",
        {.file = run.checkpoint(), .key = "meta.reward_target"});
  meta.step = loaded.step;
  meta.adamw_step = loaded.adamw_step;
  if (writer) run.Resumed(meta.step, Manifest(run, meta, sampler.DataProvenance()));
  return meta.step;
}

// One data-parallel step of the world model (this rank's rows of the global batch).
class DynamicsStage : public trainkit::TrainingStage {
 public:
  DynamicsStage(const TrainOptions& o, const trainkit::RunDir& run, const torch::Device& device,
                const SegmentSampler& sampler, const std::optional<SegmentSampler>& val, Trainee& t,
                CheckpointMeta& meta, TrainSummary& summary)
      : o_(o),
        cfg_(o.config),
        run_(run),
        device_(device),
        sampler_(sampler),
        val_(val),
        t_(t),
        meta_(meta),
        summary_(summary),
        reducer_({o.rank, o.world_size, o.launched, o.master_addr, o.master_port}, device) {
    if (reducer_.backend() != "none" && o.rank == 0) {
      LogInfo("data parallel: " + std::to_string(o.world_size) +
              (o.world_size == 1 ? " rank, " : " ranks, ") + reducer_.backend() + " backend");
    }
  }

  int64_t UnitsPerStep() const override {  // tokens
    return int64_t{cfg_.train.batch_size} * cfg_.model.context_frames * sampler_.tokens_per_frame();
  }

  void Train(int64_t step, int64_t) override {
    const TrainConfig& tc = cfg_.train;
    const int64_t local = tc.batch_size / o_.world_size, first_row = o_.rank * local;
    timer_.StartStep();
    sampler_.Fill(sampler_.Draw(tc.seed, step, tc.batch_size), first_row, local, data_);
    SegmentBatch batch =
        MakeSegmentBatch(cfg_, data_, DrawStepNoise(cfg_, tc.seed, step, tc.batch_size), first_row,
                         o_.world_size, device_);
    timer_.Mark("batch");
    lr_ = LearningRateAt(tc, step);
    t_.adamw->set_lr(lr_);
    t_.adamw->ZeroGrad();
    {
      AutocastScope autocast(device_.is_cuda() && tc.bf16);
      losses_ = t_.model->Losses(batch);
    }
    timer_.Mark("forward");
    losses_.total.backward();
    timer_.Mark("backward");
    std::vector<torch::Tensor> grads;
    for (auto& p : t_.all_params) {
      if (!p.grad().defined()) p.mutable_grad() = torch::zeros_like(p);
      grads.push_back(p.grad());
    }
    reducer_.AllReduceMean(grads);
    // Separate clipping: z is stop-gradient, so the two losses train disjoint parameters.
    Clip(t_.dyn_params, tc.grad_clip);
    Clip(t_.policy_params, tc.grad_clip);
    timer_.Mark("all-reduce + clip");
    t_.adamw->Step();
    timer_.Mark("optimizer");
  }

  std::string StepTimes() const { return timer_.Summary(); }

  std::optional<trainkit::MetricsRow> Finish(const trainkit::StepInfo& info) override {
    const bool val_now =
        val_ && o_.rank == 0 && (info.step % cfg_.train.val_every == 0 || info.last);
    if (val_now) {
      std::tie(summary_.last_val_token_ce, summary_.last_val_token_accuracy) =
          Validate(t_.model, *val_, cfg_, device_);
    }
    if (!info.first && !info.log_row && !info.last) return std::nullopt;
    const std::vector<double> s = Statistics();  // all ranks: it all-reduces
    if (info.first) summary_.first_loss = s[0];
    summary_.last_loss = s[0];
    summary_.last_token_ce = s[1];
    summary_.last_token_accuracy = s[2];
    if (!info.log_row) return std::nullopt;
    std::ostringstream before, after;
    before << s[0] << ',' << s[1] << ',' << s[2] << ',' << s[3] << ',' << s[4] << ',' << s[5] << ','
           << s[6] << ',' << lr_;
    after << ',';
    if (val_now)
      after << summary_.last_val_token_ce << ',' << summary_.last_val_token_accuracy;
    else
      after << ',';
    return trainkit::MetricsRow{.before = before.str(), .after = after.str()};
  }

  void SaveCheckpoint(int64_t step) override {
    meta_.step = step;
    meta_.adamw_step = t_.adamw->step_count();
    ::wm::train::SaveCheckpoint(run_, t_.model, *t_.adamw, meta_, sampler_.DataProvenance());
  }

 private:
  // The metrics.csv losses of the last step, averaged over the ranks.
  std::vector<double> Statistics() {
    const WorldModelLosses& l = losses_;
    torch::Tensor stats = torch::stack(
        {l.total.detach().to(torch::kFloat), l.token_ce.detach().to(torch::kFloat),
         torch::scalar_tensor(l.token_accuracy, torch::kFloat).to(device_),
         l.reward_mse.detach().to(torch::kFloat), l.terminal_bce.detach().to(torch::kFloat),
         l.policy ? l.policy->nll.detach().to(torch::kFloat) : torch::zeros({}, device_),
         l.policy ? l.policy->kl.detach().to(torch::kFloat) : torch::zeros({}, device_)});
    reducer_.AllReduceMean({stats});
    stats = stats.to(torch::kCPU, torch::kDouble).contiguous();
    return {stats.data_ptr<double>(), stats.data_ptr<double>() + stats.numel()};
  }

  const TrainOptions& o_;
  const DynamicsConfig& cfg_;
  const trainkit::RunDir& run_;
  const torch::Device device_;
  const SegmentSampler& sampler_;
  const std::optional<SegmentSampler>& val_;
  Trainee& t_;
  CheckpointMeta& meta_;
  TrainSummary& summary_;
  GradientReducer reducer_;
  trainkit::PhaseTimer timer_{device_.is_cuda()};  // WM_STEP_TIMES=1 (docs/gpu.md)
  SegmentData data_;
  WorldModelLosses losses_;  // of the last step
  double lr_ = 0;
};

}  // namespace

double LearningRateAt(const TrainConfig& t, int64_t step) {
  return trainkit::LearningRateAt(trainkit::ScheduleOf(t), step);
}

TrainSummary TrainDynamics(const TrainOptions& options) {
  const TrainConfig& tc = options.config.train;
  ValidateConfig(options.config, "(config)");
  trainkit::CheckDevice(options.device);
  const torch::Device device(options.device);
  Check(tc.batch_size % options.world_size == 0,
        "train.batch_size " + std::to_string(tc.batch_size) + " is not divisible by " +
            std::to_string(options.world_size) + " data-parallel ranks",
        {.key = "train.batch_size"});
  const bool writer = options.rank == 0;
  const trainkit::RunDir run(options.out_dir, options.resume, /*create=*/writer);
  const SegmentSampler sampler(options.token_dirs, options.config.model.context_frames,
                               options.config.data.mixture);
  CheckTokensFit(sampler, options.config.model);
  // The model takes the data's action width (the widest dataset's; docs/dynamics.md).
  TrainOptions o = options;
  o.config.model.action_dim = static_cast<int>(sampler.action_dim());
  o.config.model.levels = sampler.levels();  // a residual tokenizer's codes per cell
  std::optional<SegmentSampler> val;
  if (!o.val_dir.empty()) {
    val.emplace(std::vector<std::string>{o.val_dir}, o.config.model.context_frames, "",
                sampler.action_dim());
  }
  const std::optional<trainkit::Parent> parent = ReadDynamicsParent(o);
  trainkit::SetUpTorch(tc.threads, tc.seed, device.is_cuda());
  Trainee trainee(o.config, device, FrozenPrefixes(o));
  CheckpointMeta meta = NewRunMeta(o.config, sampler);
  if (parent) AdoptParent(*parent, meta);
  // Resuming takes precedence: a killed fine-tune continues from its own checkpoint.
  const int64_t start = run.resuming() ? Resume(run, writer, sampler, trainee, meta) : 0;
  if (parent && !run.resuming()) trainkit::LoadParentModule(*parent, *trainee.model);

  TrainSummary summary{.start_step = start, .num_parameters = trainee.num_parameters};
  DynamicsStage stage(o, run, device, sampler, val, trainee, meta, summary);
  std::optional<trainkit::StepLog> metrics;
  if (writer) metrics.emplace(run.File(kMetrics), kMetricsHeader, start);
  trainkit::LoopOptions loop = trainkit::LoopOptionsOf(tc, start, o.max_steps_this_run,
                                                       o.show_progress ? "dynamics train" : "");
  loop.writer = writer;
  const auto run_start = std::chrono::steady_clock::now();
  summary.end_step = trainkit::RunTrainingLoop(loop, stage, metrics ? &*metrics : nullptr);
  const double secs =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - run_start).count();
  if (secs > 0) {
    summary.steps_per_second = (summary.end_step - start) / secs;
    summary.tokens_per_second = summary.steps_per_second * stage.UnitsPerStep();
  }
  if (const std::string times = stage.StepTimes(); !times.empty() && o.rank == 0) {
    LogInfo("step phases: " + times);
  }
  summary.checkpoint_path = run.checkpoint();
  return summary;
}

}  // namespace wm::train

#include "train/trainer.h"

#include <ATen/autocast_mode.h>
#include <torch/torch.h>

#include <chrono>
#include <optional>
#include <sstream>

#include "core/error.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/provenance.h"
#include "train/batch.h"
#include "train/checkpoint.h"
#include "train/distributed.h"
#include "trainkit/adamw.h"
#include "trainkit/run_dir.h"
#include "trainkit/schedule.h"
#include "trainkit/step_log.h"
#include "trainkit/torch_runtime.h"

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
    torch::Tensor logits = model
                               ->NextFrameLogits(b.tokens.slice(1, 0, T - 1),
                                                 b.actions.slice(1, 0, T - 1),
                                                 z.defined() ? z.slice(1, 0, T - 1) : z)
                               .to(torch::kFloat);  // [B, N, K]
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

}  // namespace

double LearningRateAt(const TrainConfig& t, int64_t step) {
  return trainkit::LearningRateAt(
      {.max_lr = t.max_lr, .min_lr = t.min_lr, .warmup_steps = t.warmup_steps, .steps = t.steps},
      step);
}

TrainSummary TrainDynamics(const TrainOptions& o) {
  const DynamicsConfig& cfg = o.config;
  const TrainConfig& tc = cfg.train;
  ValidateConfig(cfg, "(config)");
  const torch::Device device(o.device);
  Check(!device.is_cuda() || torch::cuda::is_available(),
        "--device " + o.device + " requested but CUDA is not available");
  Check(tc.batch_size % o.world_size == 0,
        "train.batch_size " + std::to_string(tc.batch_size) + " is not divisible by " +
            std::to_string(o.world_size) + " data-parallel ranks",
        {.key = "train.batch_size"});
  const bool writer = o.rank == 0;
  const trainkit::RunDir run(o.out_dir, o.resume, /*create=*/writer);
  const nlohmann::json config_json = ConfigToJson(cfg);
  const std::string config_hash = ConfigHash(config_json);

  SegmentSampler sampler(o.token_dirs, cfg.model.context_frames, cfg.data.mixture);
  Check(sampler.grid_h() == cfg.model.grid_h && sampler.grid_w() == cfg.model.grid_w,
        "token data has " + std::to_string(sampler.grid_h()) + "x" +
            std::to_string(sampler.grid_w()) + " tokens per frame, config says " +
            std::to_string(cfg.model.grid_h) + "x" + std::to_string(cfg.model.grid_w),
        {.key = "model.grid_h"});
  Check(sampler.num_codes() == cfg.model.num_codes,
        "token data has " + std::to_string(sampler.num_codes()) + " codes, config says " +
            std::to_string(cfg.model.num_codes),
        {.key = "model.num_codes"});
  std::optional<SegmentSampler> val;
  if (!o.val_dir.empty())
    val.emplace(std::vector<std::string>{o.val_dir}, cfg.model.context_frames);

  trainkit::SetUpTorch(tc.threads, tc.seed, device.is_cuda());
  WorldModel model(cfg);
  model->to(device);
  std::vector<std::pair<std::string, torch::Tensor>> named;
  std::vector<torch::Tensor> dyn_params, policy_params, all_params;
  int64_t num_parameters = 0;
  for (const auto& item : model->named_parameters()) {
    named.emplace_back(item.key(), item.value());
    (item.key().rfind("policy.", 0) == 0 ? policy_params : dyn_params).push_back(item.value());
    all_params.push_back(item.value());
    num_parameters += item.value().numel();
  }
  trainkit::AdamW adamw(
      named,
      trainkit::AdamWOptions{
          .lr = tc.max_lr, .beta1 = tc.beta1, .beta2 = tc.beta2, .weight_decay = tc.weight_decay});
  CheckpointMeta meta;
  meta.config = config_json;
  meta.config_hash = config_hash;
  meta.action_norms = sampler.ActionNorms();
  meta.tokenizer = {
      {"checkpoint_sha256", sampler.DataProvenance()[0].at("tokenizer_checkpoint_sha256")},
      {"num_codes", sampler.num_codes()},
      {"grid_h", sampler.grid_h()},
      {"grid_w", sampler.grid_w()}};
  meta.rng = {{"scheme",
               "counter: mt19937_64(MixSeed(seed, step)) segments, torch CPU generator "
               "noise; no state beyond seed and step"},
              {"seed", tc.seed}};
  int64_t step = 0;
  if (run.resuming()) {
    const CheckpointMeta loaded = LoadCheckpoint(run.checkpoint(), model, &adamw, &config_json);
    Check(loaded.reward_target == kRewardTargetFrame,
          "checkpoint trained with the earlier reward alignment (position j predicting step j-1); "
          "resuming would switch its reward target mid-run: start a new run directory",
          {.file = run.checkpoint(), .key = "meta.reward_target"});
    step = meta.step = loaded.step;
    meta.adamw_step = loaded.adamw_step;
    if (writer) {
      LogInfo("resuming " + run.checkpoint() + " at step " + std::to_string(step));
      run.WriteManifest(Manifest(run, meta, sampler.DataProvenance()));  // maybe an older archive
    }
  }
  GradientReducer reducer({o.rank, o.world_size, o.master_addr, o.master_port}, device);
  if (o.world_size > 1 && writer) {
    LogInfo("data parallel: " + std::to_string(o.world_size) + " ranks, " + reducer.backend() +
            " backend");
  }
  std::optional<trainkit::StepLog> metrics;
  if (writer) metrics.emplace(run.File(kMetrics), kMetricsHeader, step);

  TrainSummary summary;
  summary.start_step = step;
  summary.num_parameters = num_parameters;
  const int64_t stop =
      o.max_steps_this_run > 0 ? std::min(tc.steps, step + o.max_steps_this_run) : tc.steps;
  std::optional<Progress> progress;
  if (o.show_progress && writer) progress.emplace("dynamics train", stop - step, "steps");
  const int64_t local = tc.batch_size / o.world_size, first_row = o.rank * local;
  const int64_t tokens_per_step =
      int64_t{tc.batch_size} * cfg.model.context_frames * sampler.tokens_per_frame();
  const bool bf16 = device.is_cuda() && tc.bf16;
  SegmentData data;
  const auto run_start = std::chrono::steady_clock::now();
  trainkit::ThroughputWindow window;
  while (step < stop) {
    const auto refs = sampler.Draw(tc.seed, step, tc.batch_size);
    sampler.Fill(refs, first_row, local, data);
    SegmentBatch batch =
        MakeSegmentBatch(cfg, data, DrawStepNoise(cfg, tc.seed, step, tc.batch_size), first_row,
                         o.world_size, device);
    const double lr = LearningRateAt(tc, step);
    adamw.set_lr(lr);
    adamw.ZeroGrad();
    WorldModelLosses l;
    {
      AutocastScope autocast(bf16);
      l = model->Losses(batch);
    }
    l.total.backward();
    std::vector<torch::Tensor> grads;
    for (auto& p : all_params) {
      if (!p.grad().defined()) p.mutable_grad() = torch::zeros_like(p);
      grads.push_back(p.grad());
    }
    reducer.AllReduceMean(grads);
    // Separate clipping: z is stop-gradient, so the two losses train disjoint parameters.
    Clip(dyn_params, tc.grad_clip);
    Clip(policy_params, tc.grad_clip);
    adamw.Step();
    ++step;
    window.Add(tokens_per_step);
    const bool first = step == summary.start_step + 1;
    // Rows depend only on the step, so a resumed run's metrics.csv has the same rows.
    const bool log_row = step % tc.log_every == 0 || step == tc.steps;
    const bool val_now = val && writer && (step % tc.val_every == 0 || step == stop);
    if (val_now) {
      std::tie(summary.last_val_token_ce, summary.last_val_token_accuracy) =
          Validate(model, *val, cfg, device);
    }
    if (first || log_row || step == stop) {
      torch::Tensor stats = torch::stack(
          {l.total.detach().to(torch::kFloat), l.token_ce.detach().to(torch::kFloat),
           torch::scalar_tensor(l.token_accuracy, torch::kFloat).to(device),
           l.reward_mse.detach().to(torch::kFloat), l.terminal_bce.detach().to(torch::kFloat),
           l.policy ? l.policy->nll.detach().to(torch::kFloat) : torch::zeros({}, device),
           l.policy ? l.policy->kl.detach().to(torch::kFloat) : torch::zeros({}, device)});
      reducer.AllReduceMean({stats});
      stats = stats.to(torch::kCPU, torch::kDouble);
      const double* s = stats.data_ptr<double>();
      if (first) summary.first_loss = s[0];
      summary.last_loss = s[0];
      summary.last_token_ce = s[1];
      summary.last_token_accuracy = s[2];
      if (log_row && writer) {
        std::ostringstream row;
        row << step << ',' << s[0] << ',' << s[1] << ',' << s[2] << ',' << s[3] << ',' << s[4]
            << ',' << s[5] << ',' << s[6] << ',' << lr << ',' << window.TakeRate() << ',';
        if (val_now)
          row << summary.last_val_token_ce << ',' << summary.last_val_token_accuracy;
        else
          row << ',';
        metrics->Append(row.str());
      }
    }
    if (writer && (step % tc.checkpoint_every == 0 || step == stop)) {
      meta.step = step;
      meta.adamw_step = adamw.step_count();
      SaveCheckpoint(run, model, adamw, meta, sampler.DataProvenance());
    }
    if (progress) progress->Add(1);
  }
  if (progress) progress->Finish();
  const double secs =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - run_start).count();
  if (secs > 0) {
    summary.steps_per_second = (step - summary.start_step) / secs;
    summary.tokens_per_second = summary.steps_per_second * tokens_per_step;
  }
  summary.end_step = step;
  summary.checkpoint_path = run.checkpoint();
  return summary;
}

}  // namespace wm::train

#include "motion/trainer.h"

#include <ATen/CPUGeneratorImpl.h>
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/error.h"
#include "core/log.h"
#include "core/mix_bits.h"
#include "core/provenance.h"
#include "core/read_ahead.h"
#include "core/tensor_archive.h"
#include "motion/motion_net.h"
#include "motion/motion_prior.h"
#include "motion/pose_trainer.h"
#include "motion/window_sampler.h"
#include "trainkit/adamw.h"
#include "trainkit/module_archive.h"
#include "trainkit/run_dir.h"
#include "trainkit/schedule.h"
#include "trainkit/step_log.h"
#include "trainkit/torch_runtime.h"
#include "trainkit/training_loop.h"

namespace wm::motion {
namespace {

using trainkit::AdamW;
using trainkit::RunDir;

constexpr const char* kMetrics = "metrics.csv";
constexpr const char* kValMetrics = "val.csv";
// flow_px, gate: the warp net's last unrolled step; shift_px, coverage: the layers' mean
// centroid displacement over the window and the share of the start frame they cover.
constexpr const char* kWarpMetricsHeader = "step,loss,flow_px,gate,lr,frames_per_s";
constexpr const char* kLayerMetricsHeader = "step,loss,shift_px,coverage,lr,frames_per_s";
// alpha, drawn: the pose kind's mean alpha and share of pixels weighed as drawn (pose_trainer.h)
constexpr const char* kPoseMetricsHeader = "step,loss,alpha,drawn,lr,frames_per_s";
constexpr const char* kValHeader = "step,psnr,copy_last_psnr,reversed_psnr,delta_tpsnr";

struct TrainState {
  std::unique_ptr<MotionNet> model;
  std::unique_ptr<AdamW> optimizer;
  std::unique_ptr<AdamW> dynamics_optimizer;  // the pose kind's second phase
  std::unique_ptr<WindowSampler> sampler;
  int64_t step = 0;
};

// Steps of the whole run: the pose kind's dynamics phase comes after train.steps.
int64_t TotalSteps(const MotionConfig& c) {
  return c.train.steps + (c.model.kind == "pose" ? c.train.dynamics_steps : 0);
}

const char* MetricsHeader(MotionNet& net) {
  if (net.layered()) return kLayerMetricsHeader;
  return net.posed() ? kPoseMetricsHeader : kWarpMetricsHeader;
}

// What a loaded model needs beyond its weights: the action width and how to normalise actions.
nlohmann::json ActionMeta(const WindowSampler& sampler) {
  return {{"action_dim", sampler.action_dim()},
          {"action_space", sampler.action_space()},
          {"action_norms", {{sampler.dataset_name(), sampler.action_norm().ToJson()}}}};
}

nlohmann::json Manifest(const TrainOptions& o, const RunDir& run, const TrainState& s) {
  nlohmann::json manifest = run.Manifest("wm-motion train", ConfigToJson(o.config), s.step);
  manifest["model_kind"] = "motion";
  manifest["data"] = nlohmann::json::array({s.sampler->DataProvenance()});
  manifest.update(ActionMeta(*s.sampler));
  return manifest;
}

void WriteCheckpoint(const TrainOptions& o, const RunDir& run, TrainState& s) {
  TensorArchiveWriter w;
  trainkit::AddModule(w, "model/", s.model->module());
  trainkit::AddAdamW(w, *s.optimizer);
  if (s.dynamics_optimizer) trainkit::AddAdamW(w, *s.dynamics_optimizer);  // other names
  nlohmann::json meta = {{"model_kind", "motion"},
                         {"step", s.step},
                         {"adamw_step", s.optimizer->step_count()},
                         {"config", ConfigToJson(o.config)},
                         {"config_hash", ConfigHash(ConfigToJson(o.config))},
                         {"data", s.sampler->DataProvenance()}};
  meta.update(ActionMeta(*s.sampler));
  if (s.dynamics_optimizer) meta["dynamics_adamw_step"] = s.dynamics_optimizer->step_count();
  w.SetMeta(std::move(meta));
  run.WriteCheckpoint(w, [&] { return Manifest(o, run, s); });
}

void LoadCheckpoint(const std::string& path, const nlohmann::json& config, TrainState& s) {
  TensorArchiveReader r(path);
  try {
    const nlohmann::json& meta = r.meta();
    CheckResumeConfig(meta.value("config_hash", ""),
                      ConfigToJson(ConfigFromJson(meta.at("config"))), config);
    // The action statistics (and windows) come from --data: other data would change them
    // silently halfway through the run.
    Check(meta.at("data") == s.sampler->DataProvenance(),
          "checkpoint was trained on other data than --data (dataset, split or shard hashes "
          "differ): resume with the same dataset, or start a new run",
          {.key = "data"});
    trainkit::LoadModule(r, "model/", s.model->module());
    trainkit::LoadAdamW(r, meta.at("adamw_step").get<int64_t>(), *s.optimizer);
    if (s.dynamics_optimizer) {
      trainkit::LoadAdamW(r, meta.at("dynamics_adamw_step").get<int64_t>(), *s.dynamics_optimizer);
    }
    s.step = meta.at("step").get<int64_t>();
  } catch (const Error& e) {
    throw e.WithFile(path);
  } catch (const nlohmann::json::exception& e) {
    throw Error("bad checkpoint meta: " + std::string(e.what()), {.file = path});
  }
}

// The model, then the optimizer and sampler of step 0 (the model draws from the torch seed).
TrainState MakeTrainState(const TrainOptions& o, const torch::Device& device) {
  const MotionConfig& c = o.config;
  TrainState s;
  s.sampler = std::make_unique<WindowSampler>(o.data_dir, c.data.image_key, c.model.image_size,
                                              c.train.unroll);
  s.model = std::make_unique<MotionNet>(c.model, s.sampler->action_dim());
  s.model->module().to(device);
  std::vector<std::pair<std::string, torch::Tensor>> params;
  if (s.model->posed()) {
    params = s.model->pose()->AutoencoderParameters();
  } else {
    for (const auto& item : s.model->module().named_parameters())
      params.emplace_back(item.key(), item.value());
  }
  const TrainConfig& t = c.train;
  s.optimizer = std::make_unique<AdamW>(
      std::move(params),
      trainkit::AdamWOptions{
          .lr = t.max_lr, .beta1 = t.beta1, .beta2 = t.beta2, .weight_decay = t.weight_decay});
  if (s.model->posed()) {  // torch.optim.AdamW's betas, as the bench run docs/motion.md records
    s.dynamics_optimizer = std::make_unique<AdamW>(
        s.model->pose()->DynamicsParameters(),
        trainkit::AdamWOptions{
            .lr = t.dynamics_lr, .beta1 = 0.9, .beta2 = 0.999, .weight_decay = t.weight_decay});
  }
  return s;
}

// PSNR (dB) of each imagined frame against the real one, on [0, 255] values, averaged.
double MeanPsnr(const torch::Tensor& imagined, const torch::Tensor& real) {
  const torch::Tensor mse =
      ((imagined - real) * 127.5).square().flatten(2).mean(2).clamp_min(1e-10);  // [B, H]
  return (10 * torch::log10(255.0 * 255.0 / mse)).mean().item<double>();
}

// val.csv: rollouts of the first val episodes from their first frame, scored against the real
// frames, copying the first frame, and the same rollout under the reversed actions.
class Validation {
 public:
  Validation(const TrainOptions& o, const RunDir& run, const WindowSampler& train,
             int64_t resume_step)
      : log_(run.File(kValMetrics), kValHeader, resume_step) {
    const MotionConfig& c = o.config;
    const WindowSampler val(o.val_dir, c.data.image_key, c.model.image_size, 1);
    Check(val.action_dim() == train.action_dim(),
          "validation actions have " + std::to_string(val.action_dim()) +
              " values per step, the training data " + std::to_string(train.action_dim()),
          {.file = o.val_dir});
    const int S = c.model.image_size;
    for (EpisodeClip& clip : val.Episodes(c.train.val_episodes, c.train.val_horizon + 1)) {
      if (clip.frames < 2) continue;
      const ClipTensors t = RolloutTensors(clip, train.action_norm(), S);
      Clip& v = clips_.emplace_back();
      v.frames = t.frames.unsqueeze(0);
      v.actions = t.actions.unsqueeze(0);
      const torch::Tensor real = v.frames.slice(1, 1);
      copy_last_psnr_ += MeanPsnr(v.frames.select(1, 0).unsqueeze(1).expand_as(real), real);
    }
    Check(!clips_.empty(), "no validation episode has two frames", {.file = o.val_dir});
    copy_last_psnr_ /= static_cast<double>(clips_.size());  // the model does not change it
  }

  RolloutScore Run(MotionNet& model, const torch::Device& device, int64_t step) {
    model.module().eval();
    RolloutScore score;
    for (const Clip& clip : clips_) {
      const torch::Tensor first = clip.frames.select(1, 0).to(device);
      const torch::Tensor real = clip.frames.slice(1, 1).to(device);
      const torch::Tensor actions = clip.actions.to(device);
      score.psnr += MeanPsnr(Imagine(model, first, actions), real);
      score.reversed_psnr += MeanPsnr(Imagine(model, first, actions.flip({1})), real);
    }
    model.module().train();
    const double n = static_cast<double>(clips_.size());
    score.psnr /= n, score.reversed_psnr /= n;
    score.copy_last_psnr = copy_last_psnr_;
    std::ostringstream row;
    row << step << ',' << score.psnr << ',' << score.copy_last_psnr << ',' << score.reversed_psnr
        << ',' << score.delta_tpsnr();
    log_.Append(row.str());
    return score;
  }

 private:
  struct Clip {
    torch::Tensor frames;   // [1, H + 1, 3, S, S]
    torch::Tensor actions;  // [1, H, D] normalised with the training data's statistics
  };
  trainkit::StepLog log_;
  std::vector<Clip> clips_;
  double copy_last_psnr_ = 0;  // mean over clips_ of copying the first frame
};

// One step: the unrolled L1 loss of a batch of windows; the next batch is decoded on another
// thread while this one trains.
class MotionStage : public trainkit::TrainingStage {
 public:
  MotionStage(const TrainOptions& o, const RunDir& run, const torch::Device& device, TrainState& s,
              std::optional<Validation>& val, TrainSummary& summary)
      : o_(o), cfg_(o.config), run_(run), device_(device), s_(s), val_(val), summary_(summary) {}

  void Train(int64_t step, int64_t stop) override {
    if (s_.model->posed()) {
      TrainPose(step, stop);
      if (cfg_.train.calibrate_alpha && step + 1 == TotalSteps(cfg_)) CalibrateAlpha();
      return;
    }
    const int64_t B = cfg_.train.batch_size, U = cfg_.train.unroll, S = cfg_.model.image_size;
    const int64_t D = s_.sampler->action_dim();
    Batch batch = batches_.Take(step, stop, [this](int64_t k) { return Load(k); });
    const torch::Tensor frames =
        torch::from_blob(batch.frames.data(), {B, U + 2, 3, S, S}).to(device_, true, true);
    const torch::Tensor actions =
        torch::from_blob(batch.actions.data(), {B, U, D}).to(device_, true, true);
    lr_ = trainkit::LearningRateAt(trainkit::ScheduleOf(cfg_.train), step);
    s_.optimizer->set_lr(lr_);
    s_.optimizer->ZeroGrad();
    loss_ = s_.model->layered() ? LayerLoss(frames, actions, step) : WarpLoss(frames, actions);
    Update(*s_.optimizer, step);
  }

  // The pose kind: the autoencoder's steps, then the dynamics' (pose_trainer.h), each phase by
  // its own optimizer on its own schedule.
  void TrainPose(int64_t step, int64_t stop) {
    if (step < cfg_.train.steps) return TrainPoseAutoencoder(step, stop);
    const TrainConfig& t = cfg_.train;
    PoseNet& net = s_.model->pose();
    if (!dynamics_) dynamics_.emplace(net, *s_.sampler, cfg_.model.image_size, device_);
    lr_ = trainkit::LearningRateAt({.max_lr = t.dynamics_lr,
                                    .min_lr = t.min_lr,
                                    .warmup_steps = t.warmup_steps,
                                    .steps = t.dynamics_steps},
                                   step - t.steps);
    s_.dynamics_optimizer->set_lr(lr_);
    s_.dynamics_optimizer->ZeroGrad();
    loss_ = dynamics_->Loss(net, t, step);
    diagnostics_ = {torch::zeros({}), torch::zeros({})};
    Update(*s_.dynamics_optimizer, step);
  }

  // After the last step, before its checkpoint: a run resumed from that checkpoint has no step
  // left and does not shift twice.
  void CalibrateAlpha() {
    const AlphaShiftFit fit = FitAlphaShift(s_.model->pose(), *s_.sampler, cfg_.train.unroll,
                                            cfg_.model.image_size, device_);
    std::ostringstream line;
    line << "calibrated the drawn alpha on " << fit.episodes
         << " training episodes' rollouts: logit shift " << fit.shift << ", mean squared error "
         << fit.mse_before << " -> " << fit.mse_after;
    LogInfo(line.str());
  }

  void TrainPoseAutoencoder(int64_t step, int64_t stop) {
    const TrainConfig& t = cfg_.train;
    const int64_t B = t.batch_size, S = cfg_.model.image_size;
    Batch batch =
        batches_.Take(step, std::min(stop, t.steps), [this](int64_t k) { return LoadPairs(k); });
    const torch::Tensor pairs =
        torch::from_blob(batch.frames.data(), {2, B, 3, S, S}).to(device_, true, true);
    lr_ = trainkit::LearningRateAt(trainkit::ScheduleOf(t), step);
    s_.optimizer->set_lr(lr_);
    s_.optimizer->ZeroGrad();
    PoseDiagnostics d;
    loss_ = PoseAutoencoderLoss(s_.model->pose(), t, pairs[0], pairs[1], step, d);
    diagnostics_ = {d.alpha, d.drawn};
    Update(*s_.optimizer, step);
  }

  // Backward through loss_, the gradients of `optimizer`'s parameters clipped (only theirs: in
  // the pose kind's second phase the autoencoder's keep their last, stale gradients), one step.
  void Update(AdamW& optimizer, int64_t step) {
    loss_.backward();
    if (cfg_.train.grad_clip > 0) {
      std::vector<torch::Tensor> trained;
      for (const auto& named : optimizer.parameters()) trained.push_back(named.second);
      torch::nn::utils::clip_grad_norm_(trained, cfg_.train.grad_clip);
    }
    optimizer.Step();
    s_.step = step + 1;
  }

  // frames [B, U + 2, ...] (t-1, t, ..., t+U), actions [B, U, D]: the mean L1 of U steps, each
  // predicted from the last prediction.
  torch::Tensor WarpLoss(const torch::Tensor& frames, const torch::Tensor& actions) {
    const int64_t U = actions.size(1);
    torch::Tensor previous = frames.select(1, 0), current = frames.select(1, 1);
    torch::Tensor loss = torch::zeros({}, frames.options());
    WarpStep last;
    for (int64_t u = 0; u < U; ++u) {  // the model's own prediction feeds the next step
      last = s_.model->warp()->forward(current, previous, actions.select(1, u));
      loss = loss + (last.next - frames.select(1, u + 2)).abs().mean() / static_cast<double>(U);
      previous = current;
      current = last.next;
    }
    diagnostics_ = {last.flow.detach().norm(2, 1).mean(), last.gate.detach().mean()};
    return loss;
  }

  // The layers of frame t moved through the window: the mean L1 of its U frames (moved pixels
  // weighed by train.moved_weight), plus train.mask_l1 x the layers' mean mask and the fading
  // motion prior (motion_prior.h); the mask logits noised as the schedule says.
  torch::Tensor LayerLoss(const torch::Tensor& frames, const torch::Tensor& actions, int64_t step) {
    const int64_t U = actions.size(1);
    LayerNet& net = s_.model->layers();
    LayerRollout r = net->Start(frames.select(1, 1), MaskNoise(frames, step));
    const double prior = MotionPriorWeight(cfg_.train, step);
    torch::Tensor moved;
    if (prior > 0 || cfg_.train.moved_weight > 0) moved = MovedPixels(frames, 1);
    const torch::Tensor weights = MovedLossWeights(moved, cfg_.train.moved_weight);
    torch::Tensor loss = torch::zeros({}, frames.options());
    for (int64_t u = 0; u < U; ++u) {
      const torch::Tensor next = net->Advance(r, actions.select(1, u));
      loss = loss + FrameL1(next, frames.select(1, u + 2), weights) / static_cast<double>(U);
    }
    const torch::Tensor& masks = r.sprites.masks;
    loss = loss + cfg_.train.mask_l1 * masks.mean({0, 2, 3}).sum();
    if (prior > 0) loss = loss + prior * MotionPriorLoss(masks, moved);
    torch::NoGradGuard no_grad;
    diagnostics_ = {(ApplyMaps(r.maps, r.centre0) - r.centre0).norm(2, -1).mean(),
                    1 - torch::prod(1 - masks, 1).mean()};
    return loss;
  }

  // Gaussian noise for the mask logits of this step's batch, of std train.mask_noise grown
  // linearly over the first train.mask_noise_ramp of the steps; drawn from a generator seeded
  // by (seed, step), so a resumed run draws what an uninterrupted one does. Undefined when 0.
  torch::Tensor MaskNoise(const torch::Tensor& frames, int64_t step) const {
    const TrainConfig& t = cfg_.train;
    const double ramp = std::max(1.0, t.mask_noise_ramp * static_cast<double>(t.steps));
    const double sigma = t.mask_noise * std::min(1.0, static_cast<double>(step) / ramp);
    if (sigma <= 0) return {};
    const int64_t B = frames.size(0), S = frames.size(-1);
    at::Generator generator =
        at::detail::createCPUGenerator(MixBits(t.seed ^ MixBits(static_cast<uint64_t>(step))));
    const torch::Tensor noise =
        torch::randn({B, s_.model->layers()->layers(), S, S}, generator, torch::kFloat32);
    return (noise * sigma).to(frames.device());
  }

  int64_t UnitsPerStep() const override {
    return cfg_.train.batch_size * cfg_.train.unroll;  // predicted frames
  }

  std::optional<trainkit::MetricsRow> Finish(const trainkit::StepInfo& info) override {
    std::optional<trainkit::MetricsRow> row;
    if (info.first || info.log_row || info.last) {
      const double loss = loss_.item<double>();
      if (info.first) summary_.first_loss = loss;
      summary_.last_loss = loss;
      if (info.log_row) {
        std::ostringstream before;
        before << loss << ',' << diagnostics_.first.item<double>() << ','
               << diagnostics_.second.item<double>() << ',' << lr_;
        row = trainkit::MetricsRow{.before = before.str()};
      }
    }
    if (val_ && trainkit::IsValidationStep(info.step, TotalSteps(cfg_), cfg_.train.val_every)) {
      summary_.val = val_->Run(*s_.model, device_, info.step);
    }
    return row;
  }

  void SaveCheckpoint(int64_t) override { WriteCheckpoint(o_, run_, s_); }

 private:
  struct Batch {
    std::vector<float> frames, actions;
  };

  Batch Load(int64_t step) const {
    const int B = cfg_.train.batch_size, U = cfg_.train.unroll, S = cfg_.model.image_size;
    Batch batch;
    batch.frames.resize(static_cast<size_t>(B) * (U + 2) * 3 * S * S);
    batch.actions.resize(static_cast<size_t>(B) * U * s_.sampler->action_dim());
    s_.sampler->Load(s_.sampler->Draw(cfg_.train.seed, step, B), batch.frames.data(),
                     batch.actions.data());
    return batch;
  }

  // The pose kind's autoencoder: frames then their sources, [2, B, 3, S, S].
  Batch LoadPairs(int64_t step) const {
    const int B = cfg_.train.batch_size, S = cfg_.model.image_size;
    Batch batch;
    batch.frames.resize(2ull * B * 3 * S * S);
    s_.sampler->LoadPairs(s_.sampler->DrawPairs(cfg_.train.seed, step, B, cfg_.train.pair_window),
                          batch.frames.data(), batch.frames.data() + batch.frames.size() / 2);
    return batch;
  }

  const TrainOptions& o_;
  const MotionConfig& cfg_;
  const RunDir& run_;
  const torch::Device device_;
  TrainState& s_;
  std::optional<Validation>& val_;
  TrainSummary& summary_;
  ReadAhead<Batch> batches_;
  std::optional<PoseDynamicsTraining> dynamics_;  // the pose kind's poses, read at its phase 2
  torch::Tensor loss_;
  // metrics.csv's two model columns for the last batch (kWarpMetricsHeader, kLayerMetricsHeader)
  std::pair<torch::Tensor, torch::Tensor> diagnostics_;
  double lr_ = 0;
};

}  // namespace

TrainSummary TrainMotion(const TrainOptions& o) {
  const MotionConfig& cfg = o.config;
  ValidateConfig(cfg, "(config)");
  trainkit::CheckDevice(o.device);
  const torch::Device device(o.device);
  const RunDir run(o.out_dir, o.resume, /*create=*/true);
  trainkit::SetUpTorch(cfg.train.threads, cfg.train.seed, device.is_cuda());
  // Saturated masks (sigmoid of noisy logits) and their products underflow into denormals,
  // which slowed the layered kind's CPU steps 2x by the end of a run; flushed to zero instead
  // (this thread: train.threads 1 computes here).
  if (cfg.model.kind != "warp") at::globalContext().setFlushDenormal(true);
  TrainState s = MakeTrainState(o, device);
  if (run.resuming()) {
    LoadCheckpoint(run.checkpoint(), ConfigToJson(cfg), s);
    run.Resumed(s.step, Manifest(o, run, s));
  }
  trainkit::StepLog metrics(run.File(kMetrics), MetricsHeader(*s.model), s.step);
  std::optional<Validation> val;
  if (!o.val_dir.empty()) val.emplace(o, run, *s.sampler, s.step);

  TrainSummary summary;
  summary.start_step = s.step;
  MotionStage stage(o, run, device, s, val, summary);
  TrainConfig schedule = cfg.train;
  schedule.steps = TotalSteps(cfg);
  summary.end_step =
      trainkit::RunTrainingLoop(trainkit::LoopOptionsOf(schedule, s.step, o.max_steps_this_run,
                                                        o.show_progress ? "motion train" : ""),
                                stage, &metrics);
  summary.checkpoint_path = run.checkpoint();
  return summary;
}

}  // namespace wm::motion

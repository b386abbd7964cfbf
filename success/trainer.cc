#include "success/trainer.h"

#include <torch/torch.h>

#include <cmath>
#include <sstream>

#include "core/error.h"
#include "core/log.h"
#include "core/provenance.h"
#include "core/read_ahead.h"
#include "core/tensor_archive.h"
#include "success/labelled_frames.h"
#include "success/success_net.h"
#include "trainkit/adamw.h"
#include "trainkit/module_archive.h"
#include "trainkit/run_dir.h"
#include "trainkit/schedule.h"
#include "trainkit/step_log.h"
#include "trainkit/torch_runtime.h"
#include "trainkit/training_loop.h"

namespace wm::success {
namespace {

using trainkit::RunDir;

constexpr const char* kMetricsHeader = "step,loss,lr,frames_per_s";
constexpr const char* kValHeader =
    "step,loss,auroc,accuracy,majority_accuracy,episode_accuracy,frames,positives";

struct TrainState {
  SuccessNet model{nullptr};
  std::unique_ptr<trainkit::AdamW> optimizer;
  std::unique_ptr<LabelledFrames> frames;
  int64_t step = 0;
};

nlohmann::json DataMeta(const TrainState& s) {
  nlohmann::json data = s.frames->provenance();
  data["success_frames"] = s.frames->positives();
  data["other_frames"] = s.frames->negatives();
  return data;
}

nlohmann::json Manifest(const TrainOptions& o, const RunDir& run, const TrainState& s) {
  nlohmann::json manifest = run.Manifest("wm-success train", ConfigToJson(o.config), s.step);
  manifest["model_kind"] = "success";
  manifest["data"] = nlohmann::json::array({DataMeta(s)});
  return manifest;
}

void WriteCheckpoint(const TrainOptions& o, const RunDir& run, TrainState& s) {
  const nlohmann::json config = ConfigToJson(o.config);
  TensorArchiveWriter w;
  trainkit::AddModule(w, "model/", *s.model);
  trainkit::AddAdamW(w, *s.optimizer);
  w.SetMeta({{"model_kind", "success"},
             {"step", s.step},
             {"adamw_step", s.optimizer->step_count()},
             {"config", config},
             {"config_hash", ConfigHash(config)},
             {"data", DataMeta(s)}});
  run.WriteCheckpoint(w, [&] { return Manifest(o, run, s); });
}

void Resume(const std::string& path, const nlohmann::json& config, TrainState& s) {
  TensorArchiveReader r(path);
  try {
    const nlohmann::json& meta = r.meta();
    CheckResumeConfig(meta.value("config_hash", ""),
                      ConfigToJson(ConfigFromJson(meta.at("config"))), config);
    Check(meta.at("data") == DataMeta(s),
          "checkpoint was trained on other data than --data (dataset, split or shard hashes "
          "differ): resume with the same dataset, or start a new run",
          {.key = "data"});
    trainkit::LoadModule(r, "model/", *s.model);
    trainkit::LoadAdamW(r, meta.at("adamw_step").get<int64_t>(), *s.optimizer);
    s.step = meta.at("step").get<int64_t>();
  } catch (const Error& e) {
    throw e.WithFile(path);
  } catch (const nlohmann::json::exception& e) {
    throw Error("bad checkpoint meta: " + std::string(e.what()), {.file = path});
  }
}

// val.csv: P(success) of every val frame against its label.
class Validation {
 public:
  Validation(const TrainOptions& o, const RunDir& run, int64_t resume_step)
      : log_(run.File("val.csv"), kValHeader, resume_step) {
    const SuccessConfig& c = o.config;
    const LabelledFrames val(o.val_dir, c.data.image_key, c.model.image_size,
                             c.data.reward_threshold, /*need_both=*/false);
    const int64_t S = c.model.image_size, n = static_cast<int64_t>(val.all().size());
    std::vector<float> pixels(static_cast<size_t>(n * 3 * S * S));
    labels_.resize(static_cast<size_t>(n));
    val.Load(val.all(), pixels.data(), labels_.data());
    frames_ = torch::from_blob(pixels.data(), {n, 3, S, S}).clone();
    for (const FrameRef& f : val.all()) episode_of_.push_back(f.episode);
  }

  ValidationScore Run(SuccessNet& model, const torch::Device& device, int64_t step) {
    torch::NoGradGuard no_grad;
    model->eval();
    std::vector<torch::Tensor> logits;
    for (int64_t i = 0; i < frames_.size(0); i += 64) {
      logits.push_back(model->forward(frames_.slice(0, i, i + 64).to(device)).to(torch::kCPU));
    }
    model->train();
    const torch::Tensor logit = torch::cat(logits);
    const torch::Tensor label = torch::from_blob(labels_.data(), {frames_.size(0)});
    const torch::Tensor p = torch::sigmoid(logit).contiguous();
    const std::vector<float> prob(p.data_ptr<float>(), p.data_ptr<float>() + p.numel());
    ValidationScore v{.loss = torch::binary_cross_entropy_with_logits(logit, label).item<double>(),
                      .auroc = Auroc(prob, labels_),
                      .frames = frames_.size(0),
                      .positives = static_cast<int64_t>(label.sum().item<double>())};
    v.accuracy = ((p > 0.5).to(torch::kFloat) == label).to(torch::kDouble).mean().item<double>();
    v.majority_accuracy =
        static_cast<double>(std::max(v.positives, v.frames - v.positives)) / v.frames;
    v.episode_accuracy = EpisodeAccuracy(prob);
    std::ostringstream row;
    row << step << ',' << v.loss << ',' << v.auroc << ',' << v.accuracy << ','
        << v.majority_accuracy << ',' << v.episode_accuracy << ',' << v.frames << ','
        << v.positives;
    log_.Append(row.str());
    return v;
  }

 private:
  // An episode is predicted a success when some frame's P > 0.5 (how wm-eval --policy decides).
  double EpisodeAccuracy(const std::vector<float>& prob) const {
    std::vector<std::pair<bool, bool>> episodes;  // (predicted, real)
    for (size_t i = 0; i < prob.size(); ++i) {
      if (i == 0 || episode_of_[i] != episode_of_[i - 1]) episodes.emplace_back(false, false);
      episodes.back().first |= prob[i] > 0.5f;
      episodes.back().second |= labels_[i] > 0.5f;
    }
    double right = 0;
    for (const auto& [predicted, real] : episodes) right += predicted == real;
    return right / static_cast<double>(episodes.size());
  }

  trainkit::StepLog log_;
  torch::Tensor frames_;  // [N, 3, S, S]
  std::vector<float> labels_;
  std::vector<int32_t> episode_of_;
};

// One step: binary cross-entropy of a balanced batch; the next batch is decoded on another
// thread while this one trains.
class SuccessStage : public trainkit::TrainingStage {
 public:
  SuccessStage(const TrainOptions& o, const RunDir& run, const torch::Device& device, TrainState& s,
               std::optional<Validation>& val, TrainSummary& summary)
      : o_(o), cfg_(o.config), run_(run), device_(device), s_(s), val_(val), summary_(summary) {}

  void Train(int64_t step, int64_t stop) override {
    const int64_t B = cfg_.train.batch_size, S = cfg_.model.image_size;
    Batch batch = batches_.Take(step, stop, [this](int64_t k) { return Load(k); });
    const torch::Tensor frames = torch::from_blob(batch.frames.data(), {B, 3, S, S}).to(device_);
    const torch::Tensor labels = torch::from_blob(batch.labels.data(), {B}).to(device_);
    lr_ = trainkit::LearningRateAt(trainkit::ScheduleOf(cfg_.train), step);
    s_.optimizer->set_lr(lr_);
    s_.optimizer->ZeroGrad();
    loss_ = torch::binary_cross_entropy_with_logits(s_.model->forward(frames), labels);
    loss_.backward();
    if (cfg_.train.grad_clip > 0) {
      torch::nn::utils::clip_grad_norm_(s_.model->parameters(), cfg_.train.grad_clip);
    }
    s_.optimizer->Step();
    s_.step = step + 1;
  }

  int64_t UnitsPerStep() const override { return cfg_.train.batch_size; }  // frames

  std::optional<trainkit::MetricsRow> Finish(const trainkit::StepInfo& info) override {
    std::optional<trainkit::MetricsRow> row;
    if (info.first || info.log_row || info.last) {
      const double loss = loss_.item<double>();
      if (info.first) summary_.first_loss = loss;
      summary_.last_loss = loss;
      if (info.log_row) {
        std::ostringstream before;
        before << loss << ',' << lr_;
        row = trainkit::MetricsRow{.before = before.str()};
      }
    }
    if (val_ && trainkit::IsValidationStep(info.step, cfg_.train.steps, cfg_.train.val_every)) {
      summary_.val = val_->Run(s_.model, device_, info.step);
    }
    return row;
  }

  void SaveCheckpoint(int64_t) override { WriteCheckpoint(o_, run_, s_); }

 private:
  struct Batch {
    std::vector<float> frames, labels;
  };

  Batch Load(int64_t step) const {
    const int B = cfg_.train.batch_size, S = cfg_.model.image_size;
    Batch batch{std::vector<float>(static_cast<size_t>(B) * 3 * S * S),
                std::vector<float>(static_cast<size_t>(B))};
    s_.frames->Load(s_.frames->Draw(cfg_.train.seed, step, B, cfg_.train.positive_fraction),
                    batch.frames.data(), batch.labels.data());
    return batch;
  }

  const TrainOptions& o_;
  const SuccessConfig& cfg_;
  const RunDir& run_;
  const torch::Device device_;
  TrainState& s_;
  std::optional<Validation>& val_;
  TrainSummary& summary_;
  ReadAhead<Batch> batches_;
  torch::Tensor loss_;
  double lr_ = 0;
};

}  // namespace

TrainSummary TrainSuccess(const TrainOptions& o) {
  const SuccessConfig& cfg = o.config;
  ValidateConfig(cfg, "(config)");
  trainkit::CheckDevice(o.device);
  const torch::Device device(o.device);
  const RunDir run(o.out_dir, o.resume, /*create=*/true);
  trainkit::SetUpTorch(cfg.train.threads, cfg.train.seed, device.is_cuda());
  TrainState s;
  s.frames = std::make_unique<LabelledFrames>(o.data_dir, cfg.data.image_key, cfg.model.image_size,
                                              cfg.data.reward_threshold,
                                              /*need_both=*/true);
  s.model = SuccessNet(cfg.model);  // draws from the torch seed
  s.model->to(device);
  std::vector<std::pair<std::string, torch::Tensor>> params;
  for (const auto& item : s.model->named_parameters())
    params.emplace_back(item.key(), item.value());
  const TrainConfig& t = cfg.train;
  s.optimizer = std::make_unique<trainkit::AdamW>(
      std::move(params),
      trainkit::AdamWOptions{
          .lr = t.max_lr, .beta1 = t.beta1, .beta2 = t.beta2, .weight_decay = t.weight_decay});
  if (run.resuming()) {
    Resume(run.checkpoint(), ConfigToJson(cfg), s);
    run.Resumed(s.step, Manifest(o, run, s));
  }
  LogInfo(std::to_string(s.frames->positives()) + " success frames and " +
          std::to_string(s.frames->negatives()) + " others in " +
          std::to_string(s.frames->num_episodes()) + " training episodes");
  trainkit::StepLog metrics(run.File("metrics.csv"), kMetricsHeader, s.step);
  std::optional<Validation> val;
  if (!o.val_dir.empty()) val.emplace(o, run, s.step);
  TrainSummary summary;
  summary.start_step = s.step;
  SuccessStage stage(o, run, device, s, val, summary);
  summary.end_step =
      trainkit::RunTrainingLoop(trainkit::LoopOptionsOf(cfg.train, s.step, o.max_steps_this_run,
                                                        o.show_progress ? "success train" : ""),
                                stage, &metrics);
  summary.checkpoint_path = run.checkpoint();
  return summary;
}

}  // namespace wm::success

#include "tokenize/trainer.h"

#include <torch/torch.h>

#include <optional>
#include <sstream>

#include "core/error.h"
#include "core/mix_bits.h"
#include "core/provenance.h"
#include "core/read_ahead.h"
#include "core/tensor_archive.h"
#include "tokenize/frame_sampler.h"
#include "tokenize/init_from.h"
#include "tokenize/tokenizer.h"
#include "tokenize/validation.h"
#include "tokenize/vqvae.h"
#include "trainkit/adamw.h"
#include "trainkit/init_from.h"
#include "trainkit/mixture.h"
#include "trainkit/module_archive.h"
#include "trainkit/run_dir.h"
#include "trainkit/schedule.h"
#include "trainkit/step_log.h"
#include "trainkit/torch_runtime.h"
#include "trainkit/training_loop.h"

namespace wm::tokenize {
namespace {

using trainkit::AdamW;
using trainkit::RunDir;

constexpr const char* kMetrics = "metrics.csv";
constexpr const char* kValMetrics = "val.csv";
constexpr const char* kMetricsHeader =
    "step,loss,recon_l1,codebook_loss,commitment,perplexity,usage,reseeded,lr,frames_per_s";
constexpr const char* kValHeader = "step,psnr,ssim,recon_l1,flicker,token_change_rate";
// Validation frames shown in TensorBoard at each validation step, originals over reconstructions.
constexpr int kSheetFrames = 8;
// Validation episodes whose consecutive frames are scored for token flicker: the demo's 16.
constexpr size_t kFlickerEpisodes = 16;

std::string RngText(const std::mt19937_64& rng) {
  std::ostringstream s;
  s << rng;
  return s.str();
}

// Everything a run needs to continue bit-identically.
struct TrainState {
  VqVae model{nullptr};
  std::unique_ptr<AdamW> optimizer;
  std::unique_ptr<FrameSampler> sampler;
  std::mt19937_64 reseed_rng;
  int64_t step = 0;
  nlohmann::json init_from;  // --init-from: trainkit::Parent::record; null without a parent
};

// Frame sampling is a pure function of (seed, step); only the dead-code draws carry state.
nlohmann::json RngJson(const TrainState& s) {
  return {{"reseed_mt19937_64", RngText(s.reseed_rng)}};
}

// checkpoint.json: describes the checkpoint.wmt in `run` (RunDir::WriteCheckpoint).
nlohmann::json Manifest(const TrainOptions& o, const RunDir& run, const TrainState& s) {
  nlohmann::json manifest =
      run.Manifest("wm-tokenize train", ConfigToJson(o.config), s.step, s.init_from);
  manifest["data"] = s.sampler->DataProvenance();
  manifest["rng"] = RngJson(s);
  return manifest;
}

void WriteCheckpoint(const TrainOptions& o, const RunDir& run, TrainState& s) {
  TensorArchiveWriter w;
  trainkit::AddModule(w, "model/", *s.model);
  trainkit::AddAdamW(w, *s.optimizer);
  nlohmann::json meta = {
      {"step", s.step},
      {"adamw_step", s.optimizer->step_count()},
      {"config", ConfigToJson(o.config)},  // makes the archive loadable on its own
      {"config_hash", ConfigHash(trainkit::HashedConfig(ConfigToJson(o.config), s.init_from))},
      {"rng", RngJson(s)}};
  if (!s.init_from.is_null()) meta["init_from"] = s.init_from;
  w.SetMeta(std::move(meta));
  run.WriteCheckpoint(w, [&] { return Manifest(o, run, s); });
}

void LoadCheckpoint(const std::string& path, const nlohmann::json& config, TrainState& s) {
  TensorArchiveReader r(path);
  try {
    const nlohmann::json& meta = r.meta();
    CheckResumeConfig(
        meta.value("config_hash", ""),
        trainkit::HashedConfig(
            meta.contains("config") ? ConfigToJson(ConfigFromJson(meta.at("config"))) : nullptr,
            meta.value("init_from", nlohmann::json())),
        trainkit::HashedConfig(config, s.init_from));
    trainkit::LoadModule(r, "model/", *s.model);
    trainkit::LoadAdamW(r, meta.at("adamw_step").get<int64_t>(), *s.optimizer);
    s.step = meta.at("step").get<int64_t>();
    std::istringstream in(meta.at("rng").at("reseed_mt19937_64").get<std::string>());
    in >> s.reseed_rng;
    Check(!in.fail(), "corrupt reseed RNG state", {.key = "meta.rng"});
  } catch (const Error& e) {
    throw e.WithFile(path);
  } catch (const nlohmann::json::exception& e) {
    throw Error("bad checkpoint meta: " + std::string(e.what()), {.file = path});
  }
}

std::unique_ptr<FrameSampler> MakeSampler(const TrainOptions& o,
                                          const std::vector<std::string>& dirs, uint64_t seed,
                                          bool use_mixture) {
  auto sampler = std::make_unique<FrameSampler>(dirs, o.config.data.image_key,
                                                o.config.model.image_size, seed);
  if (!use_mixture || o.mixture_file.empty()) return sampler;
  std::vector<double> weights =
      trainkit::MixtureWeights(trainkit::LoadMixture(o.mixture_file), o.mixture_file,
                               sampler->dataset_names(), sampler->step_counts());
  return std::make_unique<FrameSampler>(dirs, o.config.data.image_key, o.config.model.image_size,
                                        seed, weights);
}

// The model, optimizer and sampler of step 0 (in this order: they draw from the torch seed).
// Parameters under `frozen` prefixes (--freeze) get no gradient and stay out of the optimizer.
TrainState MakeTrainState(const TrainOptions& o, const torch::Device& device,
                          const std::vector<std::string>& frozen) {
  const TrainConfig& t = o.config.train;
  TrainState s;
  s.model = VqVae(o.config.model);
  s.model->to(device);
  std::vector<std::pair<std::string, torch::Tensor>> params;
  for (const auto& item : s.model->named_parameters()) {
    if (trainkit::IsFrozen(item.key(), frozen)) {
      item.value().set_requires_grad(false);
    } else {
      params.emplace_back(item.key(), item.value());
    }
  }
  s.optimizer = std::make_unique<AdamW>(
      std::move(params),
      trainkit::AdamWOptions{
          .lr = t.max_lr, .beta1 = t.beta1, .beta2 = t.beta2, .weight_decay = t.weight_decay});
  s.sampler = MakeSampler(o, o.data_dirs, t.seed, /*use_mixture=*/true);
  s.reseed_rng.seed(t.seed ^ 0x9E3779B97F4A7C15ull);
  return s;
}

// A fixed set of validation frames (drawn once with a seed derived from train.seed) and the
// val.csv rows scored on it.
class Validation {
 public:
  Validation(const TrainOptions& o, const RunDir& run, int64_t resume_step)
      : size_(o.config.model.image_size),
        log_(run.File(kValMetrics), kValHeader, resume_step),
        images_(run.dir(), "val_images", resume_step) {
    auto sampler = MakeSampler(o, o.val_dirs, MixBits(o.config.train.seed ^ 0x76616cull), false);
    const auto refs = sampler->BatchRefs(0, o.config.train.val_frames);
    frames_.resize(refs.size() * 3 * size_ * size_);
    if (o.config.model.anchor_decoder) {  // the hardest gap the decoder was trained on
      anchors_.resize(frames_.size());
      sampler->Load(refs, FixedGapAnchors(refs, o.config.train.anchor_max_gap), frames_.data(),
                    anchors_.data());
    } else {
      sampler->Load(refs, frames_.data());
    }
    for (const auto& clip : sampler->EpisodeRefs(kFlickerEpisodes)) {
      std::vector<float>& e = episodes_.emplace_back(clip.size() * 3 * size_ * size_);
      sampler->Load(clip, e.data());
    }
  }

  ReconstructionScore Run(VqVae& model, const torch::Device& device, int64_t step) {
    torch::NoGradGuard no_grad;
    const int64_t n = static_cast<int64_t>(frames_.size()) / (3 * size_ * size_);
    torch::Tensor images = torch::from_blob(frames_.data(), {n, 3, size_, size_}).to(device);
    torch::Tensor anchors;
    if (!anchors_.empty()) anchors = torch::from_blob(anchors_.data(), images.sizes()).to(device);
    torch::Tensor recon =
        model->forward(images, anchors).reconstruction.to(torch::kCPU).contiguous();
    ReconstructionScore score =
        ScoreReconstruction(frames_.data(), recon.data_ptr<float>(), n, size_);
    images_.Append(step, ReconstructionSheet("val/reconstructions", frames_.data(),
                                             recon.data_ptr<float>(), n, size_, kSheetFrames));
    const FlickerCounts flicker = Flicker(model, device);
    score.flicker = flicker.flicker();
    score.token_change_rate = flicker.change_rate();
    std::ostringstream row;
    row << step << ',' << score.psnr << ',' << score.ssim << ',' << score.l1 << ',' << score.flicker
        << ',' << score.token_change_rate;
    log_.Append(row.str());
    return score;
  }

 private:
  // Token flicker over the validation episodes' consecutive frames.
  FlickerCounts Flicker(VqVae& model, const torch::Device& device) {
    FlickerCounts total;
    const size_t frame_floats = 3ull * size_ * size_;
    for (std::vector<float>& e : episodes_) {
      const int64_t n = static_cast<int64_t>(e.size() / frame_floats);
      torch::Tensor images = torch::from_blob(e.data(), {n, 3, size_, size_}).to(device);
      torch::Tensor codes = CellCodes(model->quantizer->forward(model->Encode(images)).indices)
                                .to(torch::kCPU, torch::kInt64)
                                .contiguous();  // [n, g, g]
      std::vector<uint8_t> rgb;
      rgb.reserve(static_cast<size_t>(n) * frame_floats);
      for (int64_t t = 0; t < n; ++t) {
        const std::vector<uint8_t> frame = PlanarToRgb8(e.data() + t * frame_floats, size_);
        rgb.insert(rgb.end(), frame.begin(), frame.end());
      }
      total += CountFlicker(codes.data_ptr<int64_t>(), rgb.data(), n, size_,
                            static_cast<int>(codes.size(1)));
    }
    return total;
  }

  int size_;
  trainkit::StepLog log_;
  trainkit::ImageLog images_;  // events.out.tfevents.val_images: originals over reconstructions
  std::vector<float> frames_;
  std::vector<float> anchors_;  // with model.anchor_decoder: each frame's (FixedGapAnchors)
  std::vector<std::vector<float>> episodes_;  // [T, 3, size, size] each, for Flicker
};

// One tokenizer step: the next batch is decoded on another thread while this one trains.
class TokenizerStage : public trainkit::TrainingStage {
 public:
  TokenizerStage(const TrainOptions& o, const RunDir& run, const torch::Device& device,
                 TrainState& s, std::optional<Validation>& val, TrainSummary& summary)
      : o_(o), cfg_(o.config), run_(run), device_(device), s_(s), val_(val), summary_(summary) {
    // A fine-tune keeps its parent's codebook (no data-dependent init), and a frozen one also
    // never re-seeds dead codes, so every frame keeps its tokens.
    seed_codebook_ = s.init_from.is_null();
    dead_code_steps_ =
        s.model->quantizer->codebook.requires_grad() ? cfg_.model.dead_code_steps : 0;
  }

  void Train(int64_t step, int64_t stop) override {
    const int B = cfg_.train.batch_size, S = cfg_.model.image_size;
    std::vector<float> batch = batches_.Take(step, stop, [this](int64_t k) { return Load(k); });
    torch::Tensor images = torch::from_blob(batch.data(), {B, 3, S, S}).to(device_, true, true);
    torch::Tensor anchors;
    if (cfg_.model.anchor_decoder) {
      anchors =
          torch::from_blob(batch.data() + images.numel(), {B, 3, S, S}).to(device_, true, true);
    }
    lr_ = LearningRateAt(cfg_.train, step);
    s_.optimizer->set_lr(lr_);
    s_.optimizer->ZeroGrad();
    if (step == 0 && seed_codebook_) {
      s_.model->quantizer->SeedFromLatents(s_.model->Encode(images), s_.reseed_rng);
    }
    out_ = s_.model->forward(images, anchors);  // images: [B, 3, S, S]
    out_.loss.backward();
    if (cfg_.train.grad_clip > 0) {
      torch::nn::utils::clip_grad_norm_(s_.model->parameters(), cfg_.train.grad_clip);
    }
    s_.optimizer->Step();
    reseeded_ =
        s_.model->quantizer->UpdateUsageAndReseed(out_.quant, dead_code_steps_, s_.reseed_rng);
    s_.step = step + 1;
  }

  int64_t UnitsPerStep() const override { return cfg_.train.batch_size; }  // frames

  std::optional<trainkit::MetricsRow> Finish(const trainkit::StepInfo& info) override {
    std::optional<trainkit::MetricsRow> row;
    if (info.first || info.log_row || info.last) {
      const double loss = out_.loss.item<double>(), l1 = out_.recon_l1.item<double>();
      if (info.first) summary_.first_loss = loss;
      summary_.last_loss = loss;
      summary_.last_recon_l1 = l1;
      summary_.last_perplexity = out_.quant.perplexity;
      if (info.log_row) {
        std::ostringstream before;
        before << loss << ',' << l1 << ',' << out_.quant.codebook_loss.item<double>() << ','
               << out_.quant.commitment.item<double>() << ',' << out_.quant.perplexity << ','
               << out_.quant.usage << ',' << reseeded_ << ',' << lr_;
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
  // A batch: B frames, then (with model.anchor_decoder) their B anchors.
  std::vector<float> Load(int64_t step) const {
    const int B = cfg_.train.batch_size, S = cfg_.model.image_size;
    const size_t floats = static_cast<size_t>(B) * 3 * S * S;
    std::vector<float> batch(cfg_.model.anchor_decoder ? 2 * floats : floats);
    const std::vector<FrameRef> refs = s_.sampler->BatchRefs(step, B);
    if (cfg_.model.anchor_decoder) {
      s_.sampler->Load(refs,
                       s_.sampler->TrainingAnchors(refs, step, cfg_.train.anchor_max_gap,
                                                   cfg_.train.anchor_dropout),
                       batch.data(), batch.data() + floats);
    } else {
      s_.sampler->Load(refs, batch.data());
    }
    return batch;
  }

  const TrainOptions& o_;
  const TokenizerConfig& cfg_;
  const RunDir& run_;
  const torch::Device device_;
  TrainState& s_;
  std::optional<Validation>& val_;
  TrainSummary& summary_;
  ReadAhead<std::vector<float>> batches_;
  VqVaeOutput out_;  // of the last step
  double lr_ = 0;
  int64_t reseeded_ = 0;
  bool seed_codebook_ = true;
  int64_t dead_code_steps_ = 0;
};

}  // namespace

double LearningRateAt(const TrainConfig& t, int64_t step) {
  return trainkit::LearningRateAt(trainkit::ScheduleOf(t), step);
}

TrainSummary TrainTokenizer(const TrainOptions& o) {
  const TokenizerConfig& cfg = o.config;
  ValidateConfig(cfg, "(config)");
  trainkit::CheckDevice(o.device);
  const torch::Device device(o.device);
  const RunDir run(o.out_dir, o.resume, /*create=*/true);
  const std::optional<trainkit::Parent> parent = ReadTokenizerParent(o);
  trainkit::SetUpTorch(cfg.train.threads, cfg.train.seed, device.is_cuda());
  TrainState s = MakeTrainState(o, device, FrozenPrefixes(o));
  if (parent) s.init_from = parent->record;
  // Resuming takes precedence: a killed fine-tune continues from its own checkpoint.
  if (run.resuming()) {
    LoadCheckpoint(run.checkpoint(), ConfigToJson(cfg), s);
    run.Resumed(s.step, Manifest(o, run, s));
  } else if (parent) {
    trainkit::LoadParentModule(*parent, *s.model);
  }
  trainkit::StepLog metrics(run.File(kMetrics), kMetricsHeader, s.step);
  std::optional<Validation> val;
  if (!o.val_dirs.empty()) val.emplace(o, run, s.step);

  TrainSummary summary;
  summary.start_step = s.step;
  TokenizerStage stage(o, run, device, s, val, summary);
  summary.end_step =
      trainkit::RunTrainingLoop(trainkit::LoopOptionsOf(cfg.train, s.step, o.max_steps_this_run,
                                                        o.show_progress ? "tokenizer train" : ""),
                                stage, &metrics);
  summary.checkpoint_path = run.checkpoint();
  return summary;
}

}  // namespace wm::tokenize

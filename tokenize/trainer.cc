#include "tokenize/trainer.h"

#include <torch/torch.h>

#include <future>
#include <optional>
#include <sstream>

#include "core/error.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/provenance.h"
#include "core/tensor_archive.h"
#include "tokenize/frame_sampler.h"
#include "tokenize/tokenizer.h"
#include "tokenize/validation.h"
#include "tokenize/vqvae.h"
#include "trainkit/adamw.h"
#include "trainkit/mixture.h"
#include "trainkit/module_archive.h"
#include "trainkit/run_dir.h"
#include "trainkit/schedule.h"
#include "trainkit/step_log.h"
#include "trainkit/torch_runtime.h"

namespace wm::tokenize {
namespace {

using trainkit::AdamW;
using trainkit::RunDir;

constexpr const char* kMetrics = "metrics.csv";
constexpr const char* kValMetrics = "val.csv";
constexpr const char* kMetricsHeader =
    "step,loss,recon_l1,codebook_loss,commitment,perplexity,usage,reseeded,lr,frames_per_s";
constexpr const char* kValHeader = "step,psnr,ssim,recon_l1,flicker,token_change_rate";
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
};

// Frame sampling is a pure function of (seed, step); only the dead-code draws carry state.
nlohmann::json RngJson(const TrainState& s) {
  return {{"reseed_mt19937_64", RngText(s.reseed_rng)}};
}

// checkpoint.json: describes the checkpoint.wmt in `run` (RunDir::WriteCheckpoint).
nlohmann::json Manifest(const TrainOptions& o, const RunDir& run, const TrainState& s) {
  nlohmann::json manifest = run.Manifest("wm-tokenize train", ConfigToJson(o.config), s.step);
  manifest["data"] = s.sampler->DataProvenance();
  manifest["rng"] = RngJson(s);
  return manifest;
}

void SaveCheckpoint(const TrainOptions& o, const RunDir& run, TrainState& s,
                    const std::string& config_hash) {
  TensorArchiveWriter w;
  trainkit::AddModule(w, "model/", *s.model);
  trainkit::AddAdamW(w, *s.optimizer);
  w.SetMeta({{"step", s.step},
             {"adamw_step", s.optimizer->step_count()},
             {"config", ConfigToJson(o.config)},  // makes the archive loadable on its own
             {"config_hash", config_hash},
             {"rng", RngJson(s)}});
  run.WriteCheckpoint(w, [&] { return Manifest(o, run, s); });
}

void LoadCheckpoint(const std::string& path, const nlohmann::json& config, TrainState& s) {
  TensorArchiveReader r(path);
  try {
    const nlohmann::json& meta = r.meta();
    CheckResumeConfig(meta.value("config_hash", ""),
                      meta.contains("config") ? ConfigToJson(ConfigFromJson(meta.at("config")))
                                              : nlohmann::json(),
                      config);
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

// A fixed set of validation frames (drawn once with a seed derived from train.seed) and the
// val.csv rows scored on it.
class Validation {
 public:
  Validation(const TrainOptions& o, const RunDir& run, int64_t resume_step)
      : size_(o.config.model.image_size), log_(run.File(kValMetrics), kValHeader, resume_step) {
    auto sampler = MakeSampler(o, o.val_dirs, Mix64(o.config.train.seed ^ 0x76616cull), false);
    const auto refs = sampler->BatchRefs(0, o.config.train.val_frames);
    frames_.resize(refs.size() * 3 * size_ * size_);
    sampler->Load(refs, frames_.data());
    if (o.config.model.anchor_decoder) {  // the hardest gap the decoder was trained on
      anchors_.resize(frames_.size());
      sampler->Load(FixedGapAnchors(refs, o.config.train.anchor_max_gap), anchors_.data());
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
      torch::Tensor codes = model->quantizer->forward(model->Encode(images))
                                .indices.to(torch::kCPU, torch::kInt64)
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
  std::vector<float> frames_;
  std::vector<float> anchors_;  // with model.anchor_decoder: each frame's (FixedGapAnchors)
  std::vector<std::vector<float>> episodes_;  // [T, 3, size, size] each, for Flicker
};

}  // namespace

double LearningRateAt(const TrainConfig& t, int64_t step) {
  return trainkit::LearningRateAt(
      {.max_lr = t.max_lr, .min_lr = t.min_lr, .warmup_steps = t.warmup_steps, .steps = t.steps},
      step);
}

TrainSummary TrainTokenizer(const TrainOptions& o) {
  const TokenizerConfig& cfg = o.config;
  ValidateConfig(cfg, "(config)");
  const torch::Device device(o.device);
  Check(!device.is_cuda() || torch::cuda::is_available(),
        "--device " + o.device + " requested but CUDA is not available");
  const RunDir run(o.out_dir, o.resume, /*create=*/true);
  const nlohmann::json config_json = ConfigToJson(cfg);
  const std::string config_hash = ConfigHash(config_json);

  trainkit::SetUpTorch(cfg.train.threads, cfg.train.seed, device.is_cuda());
  TrainState s;
  s.model = VqVae(cfg.model);
  s.model->to(device);
  std::vector<std::pair<std::string, torch::Tensor>> params;
  for (const auto& item : s.model->named_parameters())
    params.emplace_back(item.key(), item.value());
  s.optimizer = std::make_unique<AdamW>(
      std::move(params), trainkit::AdamWOptions{.lr = cfg.train.max_lr,
                                                .beta1 = cfg.train.beta1,
                                                .beta2 = cfg.train.beta2,
                                                .weight_decay = cfg.train.weight_decay});
  s.sampler = MakeSampler(o, o.data_dirs, cfg.train.seed, /*use_mixture=*/true);
  s.reseed_rng.seed(cfg.train.seed ^ 0x9E3779B97F4A7C15ull);
  if (run.resuming()) {
    LoadCheckpoint(run.checkpoint(), config_json, s);
    LogInfo("resuming " + run.checkpoint() + " at step " + std::to_string(s.step));
    run.WriteManifest(Manifest(o, run, s));  // may describe an older archive
  }
  trainkit::StepLog metrics(run.File(kMetrics), kMetricsHeader, s.step);
  std::optional<Validation> val;
  if (!o.val_dirs.empty()) val.emplace(o, run, s.step);

  TrainSummary summary;
  summary.start_step = s.step;
  int64_t stop = cfg.train.steps;
  if (o.max_steps_this_run > 0) stop = std::min(stop, s.step + o.max_steps_this_run);
  std::optional<Progress> progress;
  if (o.show_progress) progress.emplace("tokenizer train", stop - s.step, "steps");
  const int B = cfg.train.batch_size, S = cfg.model.image_size;
  // The next batch is decoded on another thread while this one trains.
  // A batch: B frames, then (with model.anchor_decoder) their B anchors.
  const bool anchored = cfg.model.anchor_decoder;
  auto load = [&s, &cfg, B, S, anchored](int64_t step) {
    const size_t floats = static_cast<size_t>(B) * 3 * S * S;
    std::vector<float> batch(anchored ? 2 * floats : floats);
    const std::vector<FrameRef> refs = s.sampler->BatchRefs(step, B);
    s.sampler->Load(refs, batch.data());
    if (anchored) {
      s.sampler->Load(s.sampler->TrainingAnchors(refs, step, cfg.train.anchor_max_gap,
                                                 cfg.train.anchor_dropout),
                      batch.data() + floats);
    }
    return batch;
  };
  std::future<std::vector<float>> pending;
  if (s.step < stop) pending = std::async(std::launch::async, load, s.step);
  trainkit::ThroughputWindow window;
  while (s.step < stop) {
    std::vector<float> batch = pending.get();
    if (s.step + 1 < stop) pending = std::async(std::launch::async, load, s.step + 1);
    torch::Tensor images = torch::from_blob(batch.data(), {B, 3, S, S}).to(device, true, true);
    torch::Tensor anchors;
    if (anchored) {
      anchors =
          torch::from_blob(batch.data() + images.numel(), {B, 3, S, S}).to(device, true, true);
    }
    const double lr = LearningRateAt(cfg.train, s.step);
    s.optimizer->set_lr(lr);
    s.optimizer->ZeroGrad();
    if (s.step == 0) s.model->quantizer->SeedFromLatents(s.model->Encode(images), s.reseed_rng);
    VqVaeOutput out = s.model->forward(images, anchors);  // images: [B, 3, S, S]
    out.loss.backward();
    if (cfg.train.grad_clip > 0) {
      torch::nn::utils::clip_grad_norm_(s.model->parameters(), cfg.train.grad_clip);
    }
    s.optimizer->Step();
    const int64_t reseeded = s.model->quantizer->UpdateUsageAndReseed(
        out.quant, cfg.model.dead_code_steps, s.reseed_rng);
    ++s.step;
    window.Add(B);
    const bool first = s.step == summary.start_step + 1;
    // Rows depend only on the step, so a resumed run's metrics.csv has the same rows.
    const bool log_row = s.step % cfg.train.log_every == 0 || s.step == cfg.train.steps;
    if (first || log_row || s.step == stop) {
      const double loss = out.loss.item<double>(), l1 = out.recon_l1.item<double>();
      if (first) summary.first_loss = loss;
      summary.last_loss = loss;
      summary.last_recon_l1 = l1;
      summary.last_perplexity = out.quant.perplexity;
      if (log_row) {
        std::ostringstream row;
        row << s.step << ',' << loss << ',' << l1 << ',' << out.quant.codebook_loss.item<double>()
            << ',' << out.quant.commitment.item<double>() << ',' << out.quant.perplexity << ','
            << out.quant.usage << ',' << reseeded << ',' << lr << ',' << window.TakeRate();
        metrics.Append(row.str());
      }
    }
    if (val && (s.step == cfg.train.steps ||
                (cfg.train.val_every > 0 && s.step % cfg.train.val_every == 0))) {
      summary.val = val->Run(s.model, device, s.step);
    }
    if (s.step % cfg.train.checkpoint_every == 0 || s.step == stop) {
      SaveCheckpoint(o, run, s, config_hash);
    }
    if (progress) progress->Add(1);
  }
  if (progress) progress->Finish();
  summary.end_step = s.step;
  summary.checkpoint_path = run.checkpoint();
  return summary;
}

}  // namespace wm::tokenize

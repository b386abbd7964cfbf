#include "tokenize/trainer.h"

#include <torch/torch.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <future>
#include <numbers>
#include <optional>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/log.h"
#include "core/paths.h"
#include "core/progress.h"
#include "core/provenance.h"
#include "core/sha256.h"
#include "core/step_log.h"
#include "core/tensor_archive.h"
#include "tokenize/adamw.h"
#include "tokenize/frame_sampler.h"
#include "tokenize/mixture.h"
#include "tokenize/module_archive.h"
#include "tokenize/tokenizer.h"
#include "tokenize/validation.h"
#include "tokenize/vqvae.h"

namespace wm::tokenize {
namespace fs = std::filesystem;
namespace {

constexpr const char* kManifest = "checkpoint.json";
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

// checkpoint.json describes checkpoint.wmt and is written after it. A kill between the two
// renames leaves it describing the previous checkpoint, so resuming rewrites it from the archive.
void WriteManifest(const TrainOptions& o, const TrainState& s) {
  const std::string path = (fs::path(o.out_dir) / kCheckpointFile).string();
  nlohmann::json manifest =
      MakeProvenance("wm-tokenize train", ConfigToJson(o.config), {{"libtorch", TorchVersion()}});
  manifest["step"] = s.step;
  manifest["checkpoint"] = {
      {"file", kCheckpointFile}, {"sha256", Sha256File(path)}, {"format", kTensorArchiveFormat}};
  manifest["data"] = s.sampler->DataProvenance();
  manifest["rng"] = RngJson(s);
  WriteFileAtomically((fs::path(o.out_dir) / kManifest).string(), manifest.dump(2) + "\n");
}

void SaveCheckpoint(const TrainOptions& o, TrainState& s, const std::string& config_hash) {
  TensorArchiveWriter w;
  AddModule(w, "model/", *s.model);
  const auto& params = s.optimizer->parameters();
  for (size_t i = 0; i < params.size(); ++i) {
    AddTensor(w, "adamw/exp_avg/" + params[i].first, s.optimizer->exp_avg()[i]);
    AddTensor(w, "adamw/exp_avg_sq/" + params[i].first, s.optimizer->exp_avg_sq()[i]);
  }
  w.SetMeta({{"step", s.step},
             {"adamw_step", s.optimizer->step_count()},
             {"config", ConfigToJson(o.config)},  // makes the archive loadable on its own
             {"config_hash", config_hash},
             {"rng", RngJson(s)}});
  w.Write((fs::path(o.out_dir) / kCheckpointFile).string());  // atomic
  WriteManifest(o, s);
}

void LoadCheckpoint(const std::string& path, const nlohmann::json& config, TrainState& s) {
  TensorArchiveReader r(path);
  try {
    const nlohmann::json& meta = r.meta();
    CheckResumeConfig(meta.value("config_hash", ""),
                      meta.contains("config") ? ConfigToJson(ConfigFromJson(meta.at("config")))
                                              : nlohmann::json(),
                      config);
    LoadModule(r, "model/", *s.model);
    const auto& params = s.optimizer->parameters();
    for (size_t i = 0; i < params.size(); ++i) {
      LoadTensor(r, "adamw/exp_avg/" + params[i].first, s.optimizer->exp_avg()[i]);
      LoadTensor(r, "adamw/exp_avg_sq/" + params[i].first, s.optimizer->exp_avg_sq()[i]);
    }
    s.step = meta.at("step").get<int64_t>();
    s.optimizer->set_step_count(meta.at("adamw_step").get<int64_t>());
    std::istringstream in(meta.at("rng").at("reseed_mt19937_64").get<std::string>());
    in >> s.reseed_rng;
    Check(!in.fail(), "corrupt reseed RNG state", {.key = "meta.rng"});
  } catch (const Error& e) {
    throw e.WithFile(path);
  } catch (const nlohmann::json::exception& e) {
    throw Error("bad checkpoint meta: " + std::string(e.what()), {.file = path});
  }
}

void SetUpTorch(const TrainConfig& t, const torch::Device& device) {
  torch::set_num_threads(t.threads);
  // CPU kernels used here are deterministic for a fixed thread count; on CUDA some (bincount,
  // index_copy_) are not, so there this only warns.
  at::globalContext().setDeterministicAlgorithms(true, /*warn_only=*/device.is_cuda());
  torch::manual_seed(t.seed);
}

std::unique_ptr<FrameSampler> MakeSampler(const TrainOptions& o,
                                          const std::vector<std::string>& dirs, uint64_t seed,
                                          bool use_mixture) {
  auto sampler = std::make_unique<FrameSampler>(dirs, o.config.data.image_key,
                                                o.config.model.image_size, seed);
  if (!use_mixture || o.mixture_file.empty()) return sampler;
  std::vector<double> weights = MixtureWeights(LoadMixture(o.mixture_file), o.mixture_file,
                                               sampler->dataset_names(), sampler->step_counts());
  return std::make_unique<FrameSampler>(dirs, o.config.data.image_key, o.config.model.image_size,
                                        seed, weights);
}

// A fixed set of validation frames (drawn once with a seed derived from train.seed) and the
// val.csv rows scored on it.
class Validation {
 public:
  Validation(const TrainOptions& o, int64_t resume_step)
      : size_(o.config.model.image_size), path_((fs::path(o.out_dir) / kValMetrics).string()) {
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
    TruncateStepLog(path_, kValHeader, resume_step);
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
    std::ofstream out(path_, std::ios::app);
    out << step << ',' << score.psnr << ',' << score.ssim << ',' << score.l1 << ',' << score.flicker
        << ',' << score.token_change_rate << '\n';
    out.flush();
    Check(out.good(), "cannot append a row (disk full?)", {.file = path_});
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
  std::string path_;
  std::vector<float> frames_;
  std::vector<float> anchors_;  // with model.anchor_decoder: each frame's (FixedGapAnchors)
  std::vector<std::vector<float>> episodes_;  // [T, 3, size, size] each, for Flicker
};

}  // namespace

double LearningRateAt(const TrainConfig& t, int64_t step) {
  if (step < t.warmup_steps) return t.max_lr * static_cast<double>(step + 1) / t.warmup_steps;
  const double span = std::max<int64_t>(1, t.steps - t.warmup_steps);
  const double progress = std::min(1.0, static_cast<double>(step - t.warmup_steps) / span);
  return t.min_lr + 0.5 * (t.max_lr - t.min_lr) * (1.0 + std::cos(std::numbers::pi * progress));
}

std::string TorchVersion() { return TORCH_VERSION; }

TrainSummary TrainTokenizer(const TrainOptions& o) {
  const TokenizerConfig& cfg = o.config;
  ValidateConfig(cfg, "(config)");
  const torch::Device device(o.device);
  Check(!device.is_cuda() || torch::cuda::is_available(),
        "--device " + o.device + " requested but CUDA is not available");
  fs::create_directories(o.out_dir);
  const std::string ckpt = (fs::path(o.out_dir) / kCheckpointFile).string();
  const std::string metrics_path = (fs::path(o.out_dir) / kMetrics).string();
  Check(o.resume || !fs::exists(ckpt),
        "run directory already has a checkpoint; pass --resume or choose another --out",
        {.file = ckpt});
  const nlohmann::json config_json = ConfigToJson(cfg);
  const std::string config_hash = ConfigHash(config_json);

  SetUpTorch(cfg.train, device);
  TrainState s;
  s.model = VqVae(cfg.model);
  s.model->to(device);
  std::vector<std::pair<std::string, torch::Tensor>> params;
  for (const auto& item : s.model->named_parameters())
    params.emplace_back(item.key(), item.value());
  s.optimizer = std::make_unique<AdamW>(std::move(params),
                                        AdamWOptions{.lr = cfg.train.max_lr,
                                                     .beta1 = cfg.train.beta1,
                                                     .beta2 = cfg.train.beta2,
                                                     .weight_decay = cfg.train.weight_decay});
  s.sampler = MakeSampler(o, o.data_dirs, cfg.train.seed, /*use_mixture=*/true);
  s.reseed_rng.seed(cfg.train.seed ^ 0x9E3779B97F4A7C15ull);
  if (o.resume && fs::exists(ckpt)) {
    LoadCheckpoint(ckpt, config_json, s);
    LogInfo("resuming " + ckpt + " at step " + std::to_string(s.step));
    WriteManifest(o, s);
  }
  TruncateStepLog(metrics_path, kMetricsHeader, s.step);
  std::ofstream metrics(metrics_path, std::ios::app);
  std::optional<Validation> val;
  if (!o.val_dirs.empty()) val.emplace(o, s.step);

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
  auto window_start = std::chrono::steady_clock::now();
  int64_t window_frames = 0;
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
    window_frames += B;
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
        const auto now = std::chrono::steady_clock::now();
        const double secs = std::chrono::duration<double>(now - window_start).count();
        metrics << s.step << ',' << loss << ',' << l1 << ','
                << out.quant.codebook_loss.item<double>() << ','
                << out.quant.commitment.item<double>() << ',' << out.quant.perplexity << ','
                << out.quant.usage << ',' << reseeded << ',' << lr << ','
                << (secs > 0 ? window_frames / secs : 0.0) << '\n';
        metrics.flush();
        Check(metrics.good(), "cannot append a row (disk full?)", {.file = metrics_path});
        window_start = now;
        window_frames = 0;
      }
    }
    if (val && (s.step == cfg.train.steps ||
                (cfg.train.val_every > 0 && s.step % cfg.train.val_every == 0))) {
      summary.val = val->Run(s.model, device, s.step);
    }
    if (s.step % cfg.train.checkpoint_every == 0 || s.step == stop) {
      SaveCheckpoint(o, s, config_hash);
    }
    if (progress) progress->Add(1);
  }
  if (progress) progress->Finish();
  summary.end_step = s.step;
  summary.checkpoint_path = ckpt;
  return summary;
}

}  // namespace wm::tokenize

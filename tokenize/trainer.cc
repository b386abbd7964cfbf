#include "tokenize/trainer.h"

#include <torch/torch.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <optional>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/provenance.h"
#include "core/sha256.h"
#include "core/tensor_archive.h"
#include "tokenize/adamw.h"
#include "tokenize/frame_sampler.h"
#include "tokenize/vqvae.h"

namespace wm::tokenize {
namespace fs = std::filesystem;
namespace {

constexpr const char* kCheckpoint = "checkpoint.wmt";
constexpr const char* kManifest = "checkpoint.json";
constexpr const char* kMetrics = "metrics.csv";
constexpr const char* kMetricsHeader =
    "step,loss,recon_l1,codebook_loss,commitment,perplexity,usage,reseeded,lr,frames_per_s";

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

// Model parameters and buffers by their module path ("encoder.0.weight").
std::vector<std::pair<std::string, torch::Tensor>> ModelTensors(VqVae& model) {
  std::vector<std::pair<std::string, torch::Tensor>> out;
  for (const auto& item : model->named_parameters()) out.emplace_back(item.key(), item.value());
  for (const auto& item : model->named_buffers()) out.emplace_back(item.key(), item.value());
  return out;
}

void AddTensor(TensorArchiveWriter& w, const std::string& name, const torch::Tensor& t) {
  torch::Tensor c = t.detach().to(torch::kCPU).contiguous();
  Check(c.scalar_type() == torch::kFloat || c.scalar_type() == torch::kLong,
        "unsupported tensor type in checkpoint", {.key = name});
  w.Add(name, c.scalar_type() == torch::kFloat ? DType::kFloat32 : DType::kInt64, c.sizes().vec(),
        c.data_ptr(), c.numel() * c.element_size());
}

void LoadTensor(const TensorArchiveReader& r, const std::string& name, torch::Tensor& dst) {
  const ArchiveTensor& a = r.Get(name);
  const auto expected_type = dst.scalar_type() == torch::kFloat ? DType::kFloat32 : DType::kInt64;
  Check(a.dtype == expected_type && a.shape == dst.sizes().vec(),
        "checkpoint tensor is " + DTypeName(a.dtype) + ShapeString(a.shape) + ", model wants " +
            ShapeString(dst.sizes().vec()),
        {.file = r.path(), .key = name});
  torch::NoGradGuard no_grad;
  torch::Tensor src = torch::from_blob(const_cast<uint8_t*>(a.data), a.shape,
                                       torch::TensorOptions().dtype(dst.scalar_type()));
  dst.copy_(src);
}

void SaveCheckpoint(const TrainOptions& o, TrainState& s, const std::string& config_hash) {
  TensorArchiveWriter w;
  for (const auto& [name, t] : ModelTensors(s.model)) AddTensor(w, "model/" + name, t);
  const auto& params = s.optimizer->parameters();
  for (size_t i = 0; i < params.size(); ++i) {
    AddTensor(w, "adamw/exp_avg/" + params[i].first, s.optimizer->exp_avg()[i]);
    AddTensor(w, "adamw/exp_avg_sq/" + params[i].first, s.optimizer->exp_avg_sq()[i]);
  }
  const nlohmann::json rng = {{"sampler_mt19937_64", s.sampler->rng_state()},
                              {"reseed_mt19937_64", RngText(s.reseed_rng)}};
  w.SetMeta({{"step", s.step},
             {"adamw_step", s.optimizer->step_count()},
             {"config_hash", config_hash},
             {"rng", rng}});
  const std::string path = (fs::path(o.out_dir) / kCheckpoint).string();
  w.Write(path);  // atomic

  nlohmann::json manifest =
      MakeProvenance("wm-tokenize train", ConfigToJson(o.config), {{"libtorch", TorchVersion()}});
  manifest["step"] = s.step;
  manifest["checkpoint"] = {
      {"file", kCheckpoint}, {"sha256", Sha256File(path)}, {"format", kTensorArchiveFormat}};
  manifest["data"] = s.sampler->DataProvenance();
  manifest["rng"] = rng;
  WriteFileAtomically((fs::path(o.out_dir) / kManifest).string(), manifest.dump(2) + "\n");
}

void LoadCheckpoint(const std::string& path, const std::string& config_hash, TrainState& s) {
  TensorArchiveReader r(path);
  try {
    const nlohmann::json& meta = r.meta();
    Check(meta.value("config_hash", "") == config_hash,
          "checkpoint was trained with a different config; --resume needs the same config");
    for (auto& [name, t] : ModelTensors(s.model)) LoadTensor(r, "model/" + name, t);
    const auto& params = s.optimizer->parameters();
    for (size_t i = 0; i < params.size(); ++i) {
      LoadTensor(r, "adamw/exp_avg/" + params[i].first, s.optimizer->exp_avg()[i]);
      LoadTensor(r, "adamw/exp_avg_sq/" + params[i].first, s.optimizer->exp_avg_sq()[i]);
    }
    s.step = meta.at("step").get<int64_t>();
    s.optimizer->set_step_count(meta.at("adamw_step").get<int64_t>());
    s.sampler->set_rng_state(meta.at("rng").at("sampler_mt19937_64").get<std::string>());
    std::istringstream in(meta.at("rng").at("reseed_mt19937_64").get<std::string>());
    in >> s.reseed_rng;
    Check(!in.fail(), "corrupt reseed RNG state", {.key = "meta.rng"});
  } catch (const Error& e) {
    throw e.WithFile(path);
  } catch (const nlohmann::json::exception& e) {
    throw Error("bad checkpoint meta: " + std::string(e.what()), {.file = path});
  }
}

// Keeps the header and the rows up to `step` so a resumed run's metrics continue cleanly.
void TruncateMetrics(const std::string& path, int64_t step) {
  std::string out = std::string(kMetricsHeader) + "\n";
  if (fs::exists(path)) {
    std::istringstream in(ReadFile(path));
    std::string line;
    std::getline(in, line);
    while (std::getline(in, line)) {
      if (!line.empty() && std::stoll(line.substr(0, line.find(','))) <= step) out += line + "\n";
    }
  }
  WriteFileAtomically(path, out);
}

void SetUpTorch(const TrainConfig& t, const torch::Device& device) {
  torch::set_num_threads(t.threads);
  // CPU kernels used here are deterministic for a fixed thread count; on CUDA some (bincount,
  // index_copy_) are not, so there this only warns.
  at::globalContext().setDeterministicAlgorithms(true, /*warn_only=*/device.is_cuda());
  torch::manual_seed(t.seed);
}

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
  const std::string ckpt = (fs::path(o.out_dir) / kCheckpoint).string();
  const std::string metrics_path = (fs::path(o.out_dir) / kMetrics).string();
  Check(o.resume || !fs::exists(ckpt),
        "run directory already has a checkpoint; pass --resume or choose another --out",
        {.file = ckpt});
  const std::string config_hash = ConfigHash(ConfigToJson(cfg));

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
  s.sampler = std::make_unique<FrameSampler>(o.data_dirs, cfg.data.image_key, cfg.model.image_size,
                                             cfg.train.seed);
  s.reseed_rng.seed(cfg.train.seed ^ 0x9E3779B97F4A7C15ull);
  if (o.resume && fs::exists(ckpt)) {
    LoadCheckpoint(ckpt, config_hash, s);
    spdlog::info("resuming {} at step {}", ckpt, s.step);
  }
  TruncateMetrics(metrics_path, s.step);
  std::ofstream metrics(metrics_path, std::ios::app);

  TrainSummary summary;
  summary.start_step = s.step;
  int64_t stop = cfg.train.steps;
  if (o.max_steps_this_run > 0) stop = std::min(stop, s.step + o.max_steps_this_run);
  std::optional<Progress> progress;
  if (o.show_progress) progress.emplace("tokenizer train", stop - s.step, "steps");
  const int B = cfg.train.batch_size, S = cfg.model.image_size;
  std::vector<float> batch;
  auto window_start = std::chrono::steady_clock::now();
  int64_t window_frames = 0;
  while (s.step < stop) {
    s.sampler->NextBatch(B, batch);
    torch::Tensor images = torch::from_blob(batch.data(), {B, 3, S, S}).to(device, true, true);
    const double lr = LearningRateAt(cfg.train, s.step);
    s.optimizer->set_lr(lr);
    s.optimizer->ZeroGrad();
    VqVaeOutput out = s.model->forward(images);  // images: [B, 3, S, S]
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
        window_start = now;
        window_frames = 0;
      }
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

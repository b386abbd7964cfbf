#include "tokenize/tokenizer.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/paths.h"
#include "core/sha256.h"
#include "core/tensor_archive.h"
#include "tokenize/vqvae.h"
#include "trainkit/module_archive.h"

namespace wm::tokenize {
namespace {

constexpr int64_t kChunk = 64;  // frames per forward pass: bounds memory on long episodes

}  // namespace

struct Tokenizer::State {
  std::string path, sha256, config_hash;
  TokenizerConfig config;
  VqVae model{nullptr};
  torch::Device device{torch::kCPU};

  torch::Tensor Frames(const float* frames, int64_t n) const {
    const int S = config.model.image_size;
    return torch::from_blob(const_cast<float*>(frames), {n, 3, S, S}).to(device);
  }
};

Tokenizer::Tokenizer(const std::string& checkpoint, const std::string& device)
    : state_(std::make_unique<State>()) {
  State& s = *state_;
  s.path = CheckpointFileIn(checkpoint);
  s.device = torch::Device(device);
  Check(!s.device.is_cuda() || torch::cuda::is_available(),
        "--device " + device + " requested but CUDA is not available");
  TensorArchiveReader reader(s.path);
  try {
    s.config = ConfigFromJson(reader.meta().at("config"));
    s.config_hash = reader.meta().at("config_hash").get<std::string>();
  } catch (const nlohmann::json::exception& e) {
    throw Error(std::string("not a wmkit tokenizer checkpoint (meta.config): ") + e.what(),
                {.file = s.path});
  } catch (const Error& e) {
    throw e.WithFile(s.path);
  }
  s.model = VqVae(s.config.model);
  trainkit::LoadModule(reader, "model/", *s.model);
  s.model->to(s.device);
  s.model->eval();
  s.sha256 = Sha256File(s.path);
}

Tokenizer::~Tokenizer() = default;

const TokenizerConfig& Tokenizer::config() const { return state_->config; }
const std::string& Tokenizer::checkpoint_path() const { return state_->path; }
const std::string& Tokenizer::checkpoint_sha256() const { return state_->sha256; }
const std::string& Tokenizer::config_hash() const { return state_->config_hash; }

std::vector<uint32_t> Tokenizer::Encode(const float* frames, int64_t n) const {
  c10::InferenceMode inference;
  const int64_t per_frame = tokens_per_frame(), floats = 3 * int64_t{image_size()} * image_size();
  std::vector<uint32_t> codes(static_cast<size_t>(n * per_frame));
  for (int64_t i = 0; i < n; i += kChunk) {
    const int64_t m = std::min(kChunk, n - i);
    torch::Tensor z = state_->model->Encode(state_->Frames(frames + i * floats, m));
    torch::Tensor idx = state_->model->quantizer->NearestIndices(z).to(torch::kCPU);  // [m,L,g,g]
    const int64_t* p = idx.contiguous().data_ptr<int64_t>();
    std::copy(p, p + m * per_frame, codes.begin() + i * per_frame);
  }
  return codes;
}

std::vector<uint32_t> Tokenizer::EncodeEpisode(const float* frames, int64_t n,
                                               double margin) const {
  if (margin <= 0) return Encode(frames, n);
  Check(levels() == 1,
        "code hysteresis keeps one code per cell; this tokenizer has model.levels = " +
            std::to_string(levels()),
        {.file = state_->path});
  torch::NoGradGuard no_grad;
  const int64_t floats = 3 * int64_t{image_size()} * image_size();
  std::vector<torch::Tensor> latents;
  for (int64_t i = 0; i < n; i += kChunk) {
    latents.push_back(
        state_->model->Encode(state_->Frames(frames + i * floats, std::min(kChunk, n - i))));
  }
  torch::Tensor idx = state_->model->quantizer->StickyIndices(torch::cat(latents), margin)
                          .to(torch::kCPU)
                          .contiguous();  // [n, g, g]
  const int64_t* p = idx.data_ptr<int64_t>();
  return std::vector<uint32_t>(p, p + idx.numel());
}

std::vector<float> Tokenizer::Decode(const uint32_t* codes, int64_t n, const float* anchors) const {
  torch::NoGradGuard no_grad;
  const int g = grid();
  const int64_t per_frame = tokens_per_frame(), floats = 3 * int64_t{image_size()} * image_size();
  std::vector<float> frames(static_cast<size_t>(n * floats));
  for (int64_t i = 0; i < n; i += kChunk) {
    const int64_t m = std::min(kChunk, n - i);
    std::vector<int64_t> wide(codes + i * per_frame, codes + (i + m) * per_frame);
    for (int64_t c : wide) {
      Check(c >= 0 && c < config().model.num_codes,
            "token " + std::to_string(c) + " outside the codebook of " +
                std::to_string(config().model.num_codes),
            {.file = state_->path});
    }
    torch::Tensor idx =
        torch::tensor(wide, torch::kInt64).view({m, levels(), g, g}).to(state_->device);
    torch::Tensor anchor;
    if (anchors != nullptr && anchored()) anchor = state_->Frames(anchors + i * floats, m);
    torch::Tensor img = state_->model->Decode(state_->model->quantizer->Lookup(idx), anchor);
    img = img.clamp(-1, 1).to(torch::kCPU).contiguous();  // [m, 3, S, S]
    std::copy(img.data_ptr<float>(), img.data_ptr<float>() + m * floats,
              frames.begin() + i * floats);
  }
  return frames;
}

std::vector<float> Tokenizer::Reconstruct(const float* frames, int64_t n,
                                          const float* anchors) const {
  std::vector<uint32_t> codes = Encode(frames, n);
  return Decode(codes.data(), n, anchors);
}

std::vector<FeatureMap> Tokenizer::EncoderFeatures(const float* frames, int64_t n) const {
  torch::NoGradGuard no_grad;
  std::vector<FeatureMap> out;
  torch::Tensor x = state_->Frames(frames, n);
  auto keep = [&out](const torch::Tensor& t) {
    torch::Tensor c = t.to(torch::kCPU).contiguous();
    out.push_back({c.sizes().vec(),
                   std::vector<float>(c.data_ptr<float>(), c.data_ptr<float>() + c.numel())});
  };
  for (auto& layer : *state_->model->encoder) {
    x = layer.forward(x);
    if (std::dynamic_pointer_cast<torch::nn::ReLUImpl>(layer.ptr())) keep(x);
  }
  keep(x);
  return out;
}

std::vector<double> Tokenizer::PerceptualDistance(const float* a, const float* b, int64_t n) const {
  torch::NoGradGuard no_grad;
  const int64_t floats = 3 * int64_t{image_size()} * image_size();
  std::vector<double> out;
  for (int64_t i = 0; i < n; i += kChunk) {  // features of a chunk at a time: bounded memory
    const int64_t m = std::min(kChunk, n - i);
    std::vector<FeatureMap> fa = EncoderFeatures(a + i * floats, m);
    std::vector<FeatureMap> fb = EncoderFeatures(b + i * floats, m);
    torch::Tensor total = torch::zeros({m}, torch::kDouble);
    for (size_t l = 0; l < fa.size(); ++l) {
      auto unit = [](FeatureMap& f) {
        torch::Tensor x = torch::from_blob(f.values.data(), f.shape).to(torch::kDouble);
        return x / (x.pow(2).sum(1, true).sqrt() + 1e-10);  // [m, C, h, w], unit over channels
      };
      total += (unit(fa[l]) - unit(fb[l])).pow(2).sum(1).mean({1, 2});  // [m]
    }
    out.insert(out.end(), total.data_ptr<double>(), total.data_ptr<double>() + m);
  }
  return out;
}

std::vector<double> Tokenizer::FrameDescriptors(const float* frames, int64_t n,
                                                int64_t* dim) const {
  torch::NoGradGuard no_grad;
  const int64_t floats = 3 * int64_t{image_size()} * image_size();
  std::vector<double> out;
  for (int64_t i = 0; i < n; i += kChunk) {
    const int64_t m = std::min(kChunk, n - i);
    std::vector<torch::Tensor> pooled;
    for (FeatureMap& f : EncoderFeatures(frames + i * floats, m)) {
      pooled.push_back(torch::from_blob(f.values.data(), f.shape).to(torch::kDouble).mean({2, 3}));
    }
    torch::Tensor d = torch::cat(pooled, 1).contiguous();  // [m, sum of channels]
    *dim = d.size(1);
    out.insert(out.end(), d.data_ptr<double>(), d.data_ptr<double>() + d.numel());
  }
  return out;
}

std::vector<double> Tokenizer::ClipDescriptor(const float* frames, int64_t n) const {
  int64_t dim = 0;
  const std::vector<double> d = FrameDescriptors(frames, n, &dim);
  std::vector<double> out(static_cast<size_t>(2 * dim), 0.0);
  for (int64_t t = 0; t < n; ++t) {
    for (int64_t j = 0; j < dim; ++j) out[j] += d[t * dim + j] / n;
  }
  for (int64_t t = 0; t < n; ++t) {
    for (int64_t j = 0; j < dim; ++j) {
      const double e = d[t * dim + j] - out[j];
      out[dim + j] += e * e / n;
    }
  }
  for (int64_t j = 0; j < dim; ++j) out[dim + j] = std::sqrt(out[dim + j]);
  return out;
}

std::vector<uint8_t> PlanarToRgb8(const float* planar, int size) {
  const size_t plane = static_cast<size_t>(size) * size;
  std::vector<uint8_t> rgb(plane * 3);
  for (size_t i = 0; i < plane; ++i) {
    for (int c = 0; c < 3; ++c) {
      const float v = std::round((planar[c * plane + i] + 1.f) * 127.5f);
      rgb[3 * i + c] = static_cast<uint8_t>(std::clamp(v, 0.f, 255.f));
    }
  }
  return rgb;
}

}  // namespace wm::tokenize

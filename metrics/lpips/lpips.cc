#include "metrics/lpips/lpips.h"

#include <torch/torch.h>

#include <cstring>
#include <mutex>
#include <utility>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "core/error.h"
#include "core/tensor_archive.h"
#include "metrics/lpips/alexnet_trunk.h"
#include "metrics/lpips/lpips_ops.h"

namespace wm::metrics {
namespace {

struct LpipsNetOptions {
  std::array<int64_t, kLpipsLayers> channels = {64, 192, 384, 256, 256};
  double eps = 1e-10;  // lpips.normalize_tensor
};

// lpips.LPIPS(net='alex', version='0.1', spatial=False) in eval mode (dropout off).
struct LpipsNetImpl : torch::nn::Module {
  explicit LpipsNetImpl(LpipsNetOptions options = {}) : options(options) {
    shift = register_buffer("shift", torch::tensor({-.030f, -.088f, -.188f}).view({1, 3, 1, 1}));
    scale = register_buffer("scale", torch::tensor({.458f, .448f, .450f}).view({1, 3, 1, 1}));
    trunk = register_module("trunk", AlexNetTrunk());
    for (int l = 0; l < kLpipsLayers; ++l) {
      lins[l] = register_module(
          "lin" + std::to_string(l),
          torch::nn::Conv2d(torch::nn::Conv2dOptions(options.channels[l], 1, 1).bias(false)));
    }
  }

  // x: s(x0) then s(x1), [2B, 3, H, W] (s: the ScalingLayer). Returns the per-layer terms, [B, 5]
  // float64 on the CPU.
  torch::Tensor forward(const torch::Tensor& x) {
    const auto features = trunk->forward(x);
    std::vector<torch::Tensor> terms;
    for (int l = 0; l < kLpipsLayers; ++l) {
      terms.push_back(features[l].is_cpu()
                          ? LayerTerms(features[l], lins[l]->weight, options.eps)
                          : LayerTermsOnDevice(features[l], lins[l]->weight));  // [B]
    }
    return torch::stack(terms, 1);  // [B, 5]
  }

  // LayerTerms in torch ops, for devices other than the CPU.
  torch::Tensor LayerTermsOnDevice(const torch::Tensor& features, const torch::Tensor& lin) const {
    const int64_t batch = features.size(0) / 2;
    const torch::Tensor n = features / (torch::sqrt(features.pow(2).sum(1, true)) + options.eps);
    const torch::Tensor diff = (n.narrow(0, 0, batch) - n.narrow(0, batch, batch)).pow(2);
    return (diff.mean({2, 3}) * lin.view({1, -1})).sum(1).to(torch::kCPU, torch::kFloat64);
  }

  LpipsNetOptions options;
  torch::Tensor shift, scale;
  AlexNetTrunk trunk{nullptr};
  std::array<torch::nn::Conv2d, kLpipsLayers> lins{nullptr, nullptr, nullptr, nullptr, nullptr};
};
TORCH_MODULE(LpipsNet);

// Copies archive tensor `name` of `shape` into `target` (same shape, CPU float32).
void Load(const TensorArchiveReader& archive, const std::string& name, torch::Tensor target) {
  const std::vector<int64_t> shape(target.sizes().begin(), target.sizes().end());
  std::span<const float> values = archive.Float32(name, shape);
  target.copy_(torch::from_blob(const_cast<float*>(values.data()), shape, torch::kFloat32));
}

// Tensor names are the lpips state-dict names (docs/metrics-lpips.md, "LPIPS tensor names").
void LoadWeights(const TensorArchiveReader& archive, LpipsNetImpl& net) {
  const nlohmann::json& meta = archive.meta();
  for (const auto& [field, expected] : {std::pair{"net", "alex"}, std::pair{"version", "0.1"}}) {
    if (meta.contains(field) && meta[field] != expected) {
      throw Error(std::string("weights are for ") + field + " " + meta[field].dump() +
                      ", expected \"" + expected + "\"",
                  {.file = archive.path(), .key = std::string("meta.") + field});
    }
  }
  torch::NoGradGuard no_grad;
  Load(archive, "scaling_layer.shift", net.shift);
  Load(archive, "scaling_layer.scale", net.scale);
  const std::array<torch::nn::Conv2d, kLpipsLayers>& convs = net.trunk->convs;
  // Index of each conv in torchvision's alexnet().features, kept by lpips in its slice names.
  const std::array<int, kLpipsLayers> feature_index = {0, 3, 6, 8, 10};
  for (int l = 0; l < kLpipsLayers; ++l) {
    const std::string prefix =
        "net.slice" + std::to_string(l + 1) + "." + std::to_string(feature_index[l]);
    Load(archive, prefix + ".weight", convs[l]->weight);
    Load(archive, prefix + ".bias", convs[l]->bias);
    const std::string lin = "lin" + std::to_string(l) + ".model.1.weight";
    Load(archive, lin, net.lins[l]->weight);
    Check(net.lins[l]->weight.min().item<float>() >= 0.0f,
          "negative lin weight (LPIPS v0.1 lin weights are clamped to >= 0)",
          {.file = archive.path(), .key = lin});
  }
}

torch::Device ParseDevice(const std::string& device) {
  try {
    torch::Device d(device);
    Check(!d.is_cuda() || torch::cuda::is_available(),
          "device '" + device + "' requested but this LibTorch build or machine has no CUDA");
    return d;
  } catch (const c10::Error& e) {
    throw Error("bad torch device '" + device + "': " + e.what_without_backtrace());
  }
}

// See LpipsOptions::tune_malloc.
void TuneMalloc() {
#if defined(__GLIBC__)
  static std::once_flag once;
  std::call_once(once, [] {
    mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's maximum
    mallopt(M_TRIM_THRESHOLD, 1 << 30);
  });
#endif
}

void CheckPairs(size_t a, size_t b, int height, int width) {
  Check(a == b, "LPIPS needs pairs: " + std::to_string(a) + " images vs " + std::to_string(b));
  Check(height >= kLpipsMinSide && width >= kLpipsMinSide,
        "LPIPS (AlexNet) needs images of at least 31x31 pixels, got " + std::to_string(height) +
            "x" + std::to_string(width));
}

}  // namespace

void LpipsOptions::Check() const {
  wm::Check(batch_size >= 1, "LPIPS batch_size must be >= 1, got " + std::to_string(batch_size));
  wm::Check(threads >= 0, "LPIPS threads must be >= 0, got " + std::to_string(threads));
}

struct Lpips::State {
  std::string weights_file;
  LpipsOptions options;
  torch::Device device{torch::kCPU};
  LpipsNet net{nullptr};

  std::unique_ptr<InputScaling> scaling;  // from the loaded ScalingLayer buffers

  // images[begin, end) of a, then of b -> s(images), [2n, 3, H, W] on the device.
  template <typename T>
  torch::Tensor PairBatch(const std::vector<const T*>& a, const std::vector<const T*>& b,
                          size_t begin, size_t end, int height, int width) const {
    std::vector<const T*> images(a.begin() + begin, a.begin() + end);
    images.insert(images.end(), b.begin() + begin, b.begin() + end);
    return ScaledBatch(images, height, width, *scaling).to(device);
  }

  template <typename T>
  torch::Tensor Layers(const std::vector<const T*>& a, const std::vector<const T*>& b, int height,
                       int width) {
    CheckPairs(a.size(), b.size(), height, width);
    c10::InferenceMode inference;
    std::vector<torch::Tensor> chunks;
    for (size_t begin = 0; begin < a.size(); begin += options.batch_size) {
      const size_t end = std::min(a.size(), begin + options.batch_size);
      chunks.push_back(net->forward(PairBatch(a, b, begin, end, height, width)));  // [n, 5]
    }
    return chunks.empty() ? torch::zeros({0, kLpipsLayers}, torch::kFloat64) : torch::cat(chunks);
  }
};

Lpips::Lpips(const std::string& weights_file, std::string device)
    : Lpips(weights_file, LpipsOptions{.device = std::move(device)}) {}

Lpips::Lpips(const std::string& weights_file, const LpipsOptions& options)
    : state_(std::make_unique<State>()) {
  options.Check();
  state_->weights_file = weights_file;
  state_->options = options;
  state_->device = ParseDevice(options.device);
  if (options.threads > 0) torch::set_num_threads(options.threads);
  if (options.tune_malloc) TuneMalloc();
  const TensorArchiveReader archive(weights_file);
  state_->net = LpipsNet();
  LoadWeights(archive, *state_->net);
  state_->net->eval();
  state_->scaling = std::make_unique<InputScaling>(state_->net->shift, state_->net->scale);
  state_->net->to(state_->device);
  if (state_->device.is_cpu()) state_->net->trunk->PrepareForCpu();
}

Lpips::~Lpips() = default;
Lpips::Lpips(Lpips&&) noexcept = default;
Lpips& Lpips::operator=(Lpips&&) noexcept = default;

const std::string& Lpips::weights_file() const { return state_->weights_file; }
const LpipsOptions& Lpips::options() const { return state_->options; }

namespace {
std::vector<double> SumLayers(const torch::Tensor& layers) {  // [N, 5] float64 on CPU
  const torch::Tensor sum = layers.sum(1).contiguous();       // [N]
  return {sum.data_ptr<double>(), sum.data_ptr<double>() + sum.numel()};
}
}  // namespace

std::vector<double> Lpips::Distance(const std::vector<const uint8_t*>& a,
                                    const std::vector<const uint8_t*>& b, int height, int width) {
  return SumLayers(state_->Layers(a, b, height, width));
}

std::vector<double> Lpips::DistanceFloat(const std::vector<const float*>& a,
                                         const std::vector<const float*>& b, int height,
                                         int width) {
  return SumLayers(state_->Layers(a, b, height, width));
}

std::vector<std::array<double, kLpipsLayers>> Lpips::LayerDistances(
    const std::vector<const uint8_t*>& a, const std::vector<const uint8_t*>& b, int height,
    int width) {
  const torch::Tensor layers = state_->Layers(a, b, height, width).contiguous();
  std::vector<std::array<double, kLpipsLayers>> out(layers.size(0));
  if (!out.empty()) std::memcpy(out.data(), layers.data_ptr<double>(), layers.numel() * 8);
  return out;
}

std::vector<LpipsFeatureMap> Lpips::Features(const uint8_t* image, int height, int width) {
  CheckPairs(1, 1, height, width);
  c10::InferenceMode inference;
  const torch::Tensor scaled =
      ScaledBatch(std::vector<const uint8_t*>{image}, height, width, *state_->scaling)
          .to(state_->device);  // [1, 3, H, W]
  std::vector<LpipsFeatureMap> maps;
  for (const torch::Tensor& f : state_->net->trunk->forward(scaled)) {
    const torch::Tensor cpu = f[0].to(torch::kCPU).contiguous();  // [C, h, w]
    LpipsFeatureMap m;
    m.shape = {cpu.size(0), cpu.size(1), cpu.size(2)};
    m.data.assign(cpu.data_ptr<float>(), cpu.data_ptr<float>() + cpu.numel());
    maps.push_back(std::move(m));
  }
  return maps;
}

}  // namespace wm::metrics

#include "train/st_transformer.h"

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <functional>

#include "core/error.h"

namespace wm::train {

NormImpl::NormImpl(int64_t dim, bool rms) : rms(rms) {
  weight = register_parameter("weight", torch::ones({dim}));
  if (!rms) bias = register_parameter("bias", torch::zeros({dim}));
}

torch::Tensor NormImpl::forward(const torch::Tensor& x) {
  if (!rms) return torch::layer_norm(x, {x.size(-1)}, weight, bias, 1e-5);
  return x * torch::rsqrt(x.pow(2).mean(-1, true) + 1e-6) * weight;
}

namespace {

// On GPUs with LibTorch >= 2, attention runs as one fused kernel (FlashAttention or the
// memory-efficient one): the same function, other rounding, and no [L, L] score tensor in
// memory. CPUs keep the written-out form, which the PyTorch twin checks bit for bit.
// WM_ATTENTION=explicit forces the written-out form on GPUs too (docs/gpu.md measures both).
[[maybe_unused]] bool UseFusedAttention() {  // used by LibTorch >= 2 builds only
  static const bool fused = [] {
    const char* v = std::getenv("WM_ATTENTION");
    return v == nullptr || std::strcmp(v, "explicit") != 0;
  }();
  return fused;
}

thread_local int onednn_scopes = 0;  // OneDnnLinearScope objects alive on this thread

torch::Tensor Modulated(const torch::Tensor& h, const Modulation& m) {
  return m.scale.defined() ? h * (1 + m.scale) + m.shift : h;
}

torch::Tensor Gated(const torch::Tensor& y, const Modulation& m) {
  return m.gate.defined() ? y * m.gate : y;
}

torch::Tensor ApplyLayer(torch::nn::LinearImpl& linear, const torch::Tensor& x) {
  return ApplyLinear(x, linear.weight, linear.bias);
}

}  // namespace

torch::Tensor ApplyLinear(const torch::Tensor& x, const torch::Tensor& weight,
                          const torch::Tensor& bias) {
  if (onednn_scopes == 0 || !x.device().is_cpu() || x.scalar_type() != torch::kFloat ||
      !at::hasMKLDNN()) {
    return torch::nn::functional::linear(x, weight, bias);
  }
  auto shape = x.sizes().vec();
  shape.back() = weight.size(0);
  const torch::Tensor rows = x.reshape({-1, x.size(-1)}).contiguous().to_mkldnn();  // [M, in]
  const c10::optional<torch::Tensor> b =
      bias.defined() ? c10::optional<torch::Tensor>(bias) : c10::nullopt;
  return at::mkldnn_linear(rows, weight.contiguous(), b).to_dense().view(shape);
}

OneDnnLinearScope::OneDnnLinearScope() { ++onednn_scopes; }
OneDnnLinearScope::~OneDnnLinearScope() { --onednn_scopes; }

AttentionImpl::AttentionImpl(int64_t dim, int64_t heads) : heads(heads) {
  qkv = register_module("qkv", torch::nn::Linear(dim, 3 * dim));
  proj = register_module("proj", torch::nn::Linear(dim, dim));
}

AttentionInputs AttentionImpl::Project(const torch::Tensor& x) {
  const int64_t M = x.size(0), L = x.size(1), D = x.size(2), hd = D / heads;
  auto parts =
      ApplyLayer(*qkv, x).view({M, L, 3, heads, hd}).permute({2, 0, 3, 1, 4});  // [3,M,H,L,hd]
  return {parts[0], parts[1], parts[2]};
}

torch::Tensor AttentionImpl::Attend(const AttentionInputs& in, bool causal, int64_t span) {
  const torch::Tensor &q = in.q, &k = in.k, &v = in.v;
  const int64_t M = q.size(0), L = q.size(2), hd = q.size(3), D = heads * hd;
  const bool band = causal && span > 0 && span < L;
#if TORCH_VERSION_MAJOR >= 2
  if (q.is_cuda() && UseFusedAttention() && !band) {
    torch::Tensor out = at::scaled_dot_product_attention(q, k, v, {}, 0.0, causal);  // [M,H,L,hd]
    return proj->forward(out.transpose(1, 2).reshape({M, L, D}));
  }
#endif
  if (L == 1 && !causal && q.device().is_cpu()) {
    // One query (a frame appended to a cache) over a few keys: as products and sums rather than
    // M*H tiny matrix products, which a generic BLAS runs one call at a time.
    torch::Tensor p =
        torch::softmax((q * k).sum(-1, true) / std::sqrt(double(hd)), 2);  // [M,H,Lk,1]
    torch::Tensor out = (p * v).sum(2, true);                              // [M, H, 1, hd]
    return ApplyLayer(*proj, out.transpose(1, 2).reshape({M, L, D}));
  }
  torch::Tensor scores =
      torch::matmul(q, k.transpose(-2, -1)) / std::sqrt(double(hd));  // [M,H,L,Lk]
  if (causal) {
    const torch::Tensor ones =
        torch::ones({L, L}, torch::TensorOptions().dtype(torch::kBool).device(q.device()));
    torch::Tensor hidden = ones.triu(1);  // the future
    if (band) hidden.logical_or_(ones.tril(-span));
    scores = scores.masked_fill(hidden, -std::numeric_limits<float>::infinity());
  }
  torch::Tensor out = torch::matmul(torch::softmax(scores, -1), v);  // [M, H, L, hd]
  return ApplyLayer(*proj, out.transpose(1, 2).reshape({M, L, D}));  // [M, L, D]
}

torch::Tensor AttentionImpl::forward(const torch::Tensor& x, bool causal) {
  return Attend(Project(x), causal);
}

StBlockImpl::StBlockImpl(const StBlockOptions& o) : options(o) {
  norm1 = register_module("norm1", Norm(o.dim, o.rms_norm));
  spatial = register_module("spatial", Attention(o.dim, o.heads));
  norm2 = register_module("norm2", Norm(o.dim, o.rms_norm));
  temporal = register_module("temporal", Attention(o.dim, o.heads));
  norm3 = register_module("norm3", Norm(o.dim, o.rms_norm));
  fc1 = register_module("fc1", torch::nn::Linear(o.dim, o.mlp_ratio * o.dim));
  fc2 = register_module("fc2", torch::nn::Linear(o.mlp_ratio * o.dim, o.dim));
  if (o.adaptive_norm != AdaptiveNorm::kOff) {
    modulation = register_module("modulation", torch::nn::Linear(o.dim, 9 * o.dim));
  }
}

void StBlockImpl::ZeroModulation() {
  if (!modulation) return;
  torch::NoGradGuard no_grad;
  modulation->weight.zero_();
  modulation->bias.zero_();
}

std::array<Modulation, 3> StBlockImpl::Modulations(const torch::Tensor& cond, int64_t N) {
  if (!modulation) return {};
  Check(cond.defined(), "an adaptive-norm block needs its frames' conditioning (StInput::cond)");
  const int64_t B = cond.size(0), T = cond.size(1), D = cond.size(2);
  const auto terms = ApplyLayer(*modulation, torch::silu(cond)).chunk(9, -1);  // 9x [B, T, D]
  // Each sublayer's input layout: frames ([B*T, N, D]), grid positions ([B*N, T, D]), [B,T,N,D].
  const std::array<std::function<torch::Tensor(const torch::Tensor&)>, 3> layouts = {
      [&](const torch::Tensor& t) {
        return t.reshape({B * T, 1, D});
      },
      [&](const torch::Tensor& t) {
        return t.unsqueeze(1).expand({B, N, T, D}).reshape({B * N, T, D});
      },
      [&](const torch::Tensor& t) { return t.unsqueeze(2); }};
  const double gate_start = options.adaptive_norm == AdaptiveNorm::kZero ? 0.0 : 1.0;
  std::array<Modulation, 3> out;
  for (size_t i = 0; i < 3; ++i) {
    out[i] = {layouts[i](terms[3 * i]), layouts[i](terms[3 * i + 1]),
              layouts[i](terms[3 * i + 2] + gate_start)};
  }
  return out;
}

namespace {

struct Rotation {
  int64_t first = -1, length = 0, half = 0;
  torch::TensorOptions options;
  torch::Tensor cos, sin;  // [length, half]
};

// cos and sin of the rotary angles of frames first..first+length-1. Every block's queries and keys
// of one pass share them, so the last ones are kept (per thread: forwards on other threads do not
// race).
const Rotation& Angles(int64_t first, int64_t length, int64_t half,
                       const torch::TensorOptions& options) {
  thread_local Rotation last;
  if (last.first == first && last.length == length && last.half == half &&
      last.options.dtype() == options.dtype() && last.options.device() == options.device()) {
    return last;
  }
  const auto f64 = torch::TensorOptions().dtype(torch::kFloat64);
  // Angles in double: frame indices of long episodes times the fastest frequency keep their
  // digits, and the same frame gets the same angle whichever forward it is in.
  const torch::Tensor inv_freq = torch::pow(10000.0, -torch::arange(half, f64) / double(half));
  const torch::Tensor angle = torch::outer(torch::arange(first, first + length, f64), inv_freq);
  last = {first, length, half, options, angle.cos().to(options), angle.sin().to(options)};
  return last;
}

}  // namespace

torch::Tensor RotateByFrame(const torch::Tensor& x, int64_t first) {
  const int64_t L = x.size(2), half = x.size(3) / 2;
  const Rotation& r = Angles(first, L, half, x.options());
  const torch::Tensor x1 = x.narrow(-1, 0, half), x2 = x.narrow(-1, half, half);  // [M,H,L,hd/2]
  return torch::cat({x1 * r.cos - x2 * r.sin, x1 * r.sin + x2 * r.cos}, -1);
}

AttentionInputs StBlockImpl::TemporalInputs(const torch::Tensor& x, int64_t first,
                                            const Modulation& mod) {
  AttentionInputs in = temporal->Project(Modulated(norm2->forward(x), mod));
  if (options.rope_time) in.q = RotateByFrame(in.q, first), in.k = RotateByFrame(in.k, first);
  return in;
}

torch::Tensor StBlockImpl::Forward(const StInput& input, TemporalCache* cache,
                                   const TimeAxis& time) {
  const int64_t B = input.x.size(0), T = input.x.size(1), N = input.x.size(2), D = input.x.size(3);
  const auto mod = Modulations(input.cond, N);
  // Spatial: every frame on its own, all tokens see each other.
  torch::Tensor x = input.x.reshape({B * T, N, D});  // [B*T, N, D]
  x = x + Gated(spatial->forward(Modulated(norm1->forward(x), mod[0]), /*causal=*/false), mod[0]);
  // Temporal: every grid position on its own, causal over frames.
  x = x.view({B, T, N, D}).transpose(1, 2).reshape({B * N, T, D});  // [B*N, T, D]
  const AttentionInputs in = TemporalInputs(x, time.first, mod[1]);
  if (cache) cache->keys.push_back(in.k), cache->values.push_back(in.v);
  x = x + Gated(temporal->Attend(in, options.causal_time, time.span), mod[1]);
  x = x.view({B, N, T, D}).transpose(1, 2);  // [B, T, N, D]
  return x + MlpBranch(x, mod[2]);
}

torch::Tensor StBlockImpl::MlpBranch(const torch::Tensor& x, const Modulation& mod) {
  return Gated(ApplyLayer(*fc2, torch::gelu(ApplyLayer(*fc1, Modulated(norm3->forward(x), mod)))),
               mod);
}

torch::Tensor StBlockImpl::ForwardAppended(const StInput& input, const torch::Tensor& past_k,
                                           const torch::Tensor& past_v, int64_t index,
                                           torch::Tensor* new_k, torch::Tensor* new_v) {
  const int64_t B = input.x.size(0), N = input.x.size(2), D = input.x.size(3);
  const auto mod = Modulations(input.cond, N);
  torch::Tensor x = input.x.reshape({B, N, D});  // [B, N, D]: the new frame's tokens
  x = x + Gated(spatial->forward(Modulated(norm1->forward(x), mod[0]), /*causal=*/false), mod[0]);
  x = x.reshape({B * N, 1, D});  // [B*N, 1, D]: each grid position's new frame
  AttentionInputs in = TemporalInputs(x, index, mod[1]);
  if (new_k) *new_k = in.k, *new_v = in.v;
  // The new frame is the window's last: it sees every cached frame and itself, no mask needed.
  in.k = torch::cat({past_k, in.k}, 2), in.v = torch::cat({past_v, in.v}, 2);  // [B*N,H,T+1,hd]
  x = x + Gated(temporal->Attend(in, /*causal=*/false), mod[1]);
  x = x.view({B, 1, N, D});
  return x + MlpBranch(x, mod[2]);
}

StTransformerImpl::StTransformerImpl(const StBlockOptions& options, int64_t layers) {
  blocks = register_module("blocks", torch::nn::ModuleList());
  for (int64_t i = 0; i < layers; ++i) blocks->push_back(StBlock(options));
  norm = register_module("norm", Norm(options.dim, options.rms_norm));
}

void StTransformerImpl::ZeroModulation() {
  for (const auto& block : *blocks) block->as<StBlock>()->ZeroModulation();
}

torch::Tensor StTransformerImpl::Forward(const StInput& in, const TimeAxis& time) {
  torch::Tensor x = in.x;
  for (const auto& block : *blocks) x = block->as<StBlock>()->Forward({x, in.cond}, nullptr, time);
  return norm->forward(x);
}

torch::Tensor StTransformerImpl::ForwardCaching(const StInput& in, TemporalCache& cache) {
  cache = {};
  torch::Tensor x = in.x;
  for (const auto& block : *blocks) x = block->as<StBlock>()->Forward({x, in.cond}, &cache, {});
  return norm->forward(x);
}

torch::Tensor StTransformerImpl::ForwardAppended(const StInput& in, const TemporalCache& cache,
                                                 int64_t index, TemporalCache* appended) {
  Check(cache.keys.size() == blocks->size(), "temporal cache of another transformer");
  if (appended) {
    appended->keys.assign(blocks->size(), torch::Tensor());
    appended->values.assign(blocks->size(), torch::Tensor());
  }
  torch::Tensor x = in.x;
  for (size_t i = 0; i < blocks->size(); ++i) {
    x = blocks[i]->as<StBlock>()->ForwardAppended({x, in.cond}, cache.keys[i], cache.values[i],
                                                  index, appended ? &appended->keys[i] : nullptr,
                                                  appended ? &appended->values[i] : nullptr);
  }
  return norm->forward(x);
}

void InitWeights(torch::nn::Module& module) {
  // children() rather than modules(): the constructors call this before a shared_ptr owns them.
  torch::NoGradGuard no_grad;
  for (const auto& m : module.children()) {
    if (auto* linear = m->as<torch::nn::Linear>()) {
      linear->weight.normal_(0.0, 0.02);
      if (linear->bias.defined()) linear->bias.zero_();
    } else if (auto* emb = m->as<torch::nn::Embedding>()) {
      emb->weight.normal_(0.0, 0.02);
    } else {
      InitWeights(*m);
    }
  }
}

}  // namespace wm::train

#include "tokenize/vqvae.h"

#include <algorithm>
#include <cmath>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace wm::tokenize {
namespace F = torch::nn::functional;
namespace {

// x + conv1x1(relu(conv3x3(relu(x)))): keeps [B, C, h, w].
struct ResBlockImpl : torch::nn::Module {
  explicit ResBlockImpl(int64_t channels) {
    using torch::nn::Conv2dOptions;
    conv1 = register_module("conv1",
                            torch::nn::Conv2d(Conv2dOptions(channels, channels, 3).padding(1)));
    conv2 = register_module("conv2", torch::nn::Conv2d(Conv2dOptions(channels, channels, 1)));
  }
  torch::Tensor forward(const torch::Tensor& x) {
    return x + conv2->forward(torch::relu(conv1->forward(torch::relu(x))));
  }
  torch::nn::Conv2d conv1{nullptr}, conv2{nullptr};
};
TORCH_MODULE(ResBlock);

// F::pixel_unshuffle / F::pixel_shuffle by factor f as one view, permute and copy: the same
// values in the same contiguous layout (a pure permutation, so gradients are equal too), about
// 4-5x faster on CPU than LibTorch 1.13's dedicated kernels (docs/tokenizer.md, "Benchmark").
torch::Tensor PixelUnshuffle(const torch::Tensor& x, int64_t f) {  // [B, C, H, W]
  const int64_t B = x.size(0), C = x.size(1), h = x.size(2) / f, w = x.size(3) / f;
  return x.reshape({B, C, h, f, w, f}).permute({0, 1, 3, 5, 2, 4}).reshape({B, C * f * f, h, w});
}
torch::Tensor PixelShuffle(const torch::Tensor& x, int64_t f) {  // [B, C f^2, h, w]
  const int64_t B = x.size(0), C = x.size(1) / (f * f), h = x.size(2), w = x.size(3);
  return x.reshape({B, C, f, f, h, w}).permute({0, 1, 4, 2, 5, 3}).reshape({B, C, h * f, w * f});
}

// torch::nn::PixelUnshuffle / PixelShuffle as modules of the Sequentials (no parameters, so
// the checkpoint's names do not change), through the functions above.
struct SpaceToChannelsImpl : torch::nn::Module {
  explicit SpaceToChannelsImpl(int64_t factor) : factor(factor) {}
  torch::Tensor forward(const torch::Tensor& x) { return PixelUnshuffle(x, factor); }
  int64_t factor;
};
TORCH_MODULE(SpaceToChannels);
struct ChannelsToSpaceImpl : torch::nn::Module {
  explicit ChannelsToSpaceImpl(int64_t factor) : factor(factor) {}
  torch::Tensor forward(const torch::Tensor& x) { return PixelShuffle(x, factor); }
  int64_t factor;
};
TORCH_MODULE(ChannelsToSpace);

// Index of the smallest of row[0, K), the first one on ties, or of the first NaN: the order
// of torch's argmin. SSE2 keeps eight running minima with their first indices (a strictly
// smaller value replaces), merged by value and then index; rows with a NaN take the scalar scan.
int64_t FirstArgMin(const float* row, int64_t K) {
  int64_t k = 1, best = 0;
#if defined(__SSE2__)
  if (K >= 8) {
    __m128 lo0 = _mm_loadu_ps(row), lo1 = _mm_loadu_ps(row + 4);
    __m128 nan = _mm_or_ps(_mm_cmpunord_ps(lo0, lo0), _mm_cmpunord_ps(lo1, lo1));
    __m128i at0 = _mm_setr_epi32(0, 1, 2, 3), at1 = _mm_setr_epi32(4, 5, 6, 7);
    __m128i i0 = at0, i1 = at1;
    const __m128i eight = _mm_set1_epi32(8);
    for (k = 8; k + 8 <= K; k += 8) {
      i0 = _mm_add_epi32(i0, eight);
      i1 = _mm_add_epi32(i1, eight);
      const __m128 v0 = _mm_loadu_ps(row + k), v1 = _mm_loadu_ps(row + k + 4);
      const __m128 less0 = _mm_cmplt_ps(v0, lo0), less1 = _mm_cmplt_ps(v1, lo1);
      lo0 = _mm_or_ps(_mm_and_ps(less0, v0), _mm_andnot_ps(less0, lo0));
      lo1 = _mm_or_ps(_mm_and_ps(less1, v1), _mm_andnot_ps(less1, lo1));
      const __m128i take0 = _mm_castps_si128(less0), take1 = _mm_castps_si128(less1);
      at0 = _mm_or_si128(_mm_and_si128(take0, i0), _mm_andnot_si128(take0, at0));
      at1 = _mm_or_si128(_mm_and_si128(take1, i1), _mm_andnot_si128(take1, at1));
      nan = _mm_or_ps(nan, _mm_or_ps(_mm_cmpunord_ps(v0, v0), _mm_cmpunord_ps(v1, v1)));
    }
    if (_mm_movemask_ps(nan) == 0) {
      alignas(16) float lo[8];
      alignas(16) int32_t at[8];
      _mm_store_ps(lo, lo0);
      _mm_store_ps(lo + 4, lo1);
      _mm_store_si128(reinterpret_cast<__m128i*>(at), at0);
      _mm_store_si128(reinterpret_cast<__m128i*>(at + 4), at1);
      float value = lo[0];
      best = at[0];
      for (int j = 1; j < 8; ++j) {
        if (lo[j] < value || (lo[j] == value && at[j] < best)) value = lo[j], best = at[j];
      }
      for (; k < K; ++k) {  // the tail, past every lane's index
        if (std::isnan(row[k])) return k;
        if (row[k] < value) value = row[k], best = k;
      }
      return best;
    }
    k = 1;
  }
#endif
  for (; k < K && !std::isnan(row[best]); ++k) {
    if (!(row[k] >= row[best])) best = k;  // smaller, or NaN
  }
  return best;
}

// Each level's indices [N] -> [B, h, w] for one level, else [B, levels, h, w].
torch::Tensor StackIndices(const std::vector<torch::Tensor>& indices, int64_t B, int64_t h,
                           int64_t w) {
  if (indices.size() == 1) return indices[0].view({B, h, w});
  const int64_t L = static_cast<int64_t>(indices.size());
  return torch::stack(indices, 1).view({B, h, w, L}).permute({0, 3, 1, 2}).contiguous();
}

int Log2(int x) {
  int n = 0;
  while ((1 << n) < x) ++n;
  return n;
}

// Conv width `level` resolutions above the token grid: halved per level, floored at
// min_channels (0: constant width).
int64_t Width(const ModelConfig& c, int64_t channels, int level) {
  return c.min_channels > 0 ? std::max<int64_t>(c.min_channels, channels >> level) : channels;
}

// model.encoder "conv": the stem trades resolution for channels (pixel unshuffle) so no conv
// runs at full resolution; the strided convs do the rest of patch_size. -> [B, D, h, w]
torch::nn::Sequential ConvEncoder(const ModelConfig& c) {
  using torch::nn::Conv2dOptions;
  const int f = c.stem_factor, downs = Log2(c.patch_size / f);
  const int64_t ce = c.encoder_channels;
  torch::nn::Sequential encoder;
  if (f > 1) encoder->push_back(SpaceToChannels(f));  // [B, 3f^2, H/f, W/f]
  encoder->push_back(
      torch::nn::Conv2d(Conv2dOptions(3 * f * f, Width(c, ce, downs), 3).padding(1)));
  encoder->push_back(torch::nn::ReLU());  // [B, Ce(downs), H/f, W/f]
  for (int level = downs; level > 0; --level) {
    encoder->push_back(torch::nn::Conv2d(
        Conv2dOptions(Width(c, ce, level), Width(c, ce, level - 1), 4).stride(2).padding(1)));
    encoder->push_back(torch::nn::ReLU());  // halves H and W
  }
  for (int i = 0; i < c.encoder_layers; ++i) encoder->push_back(ResBlock(ce));
  encoder->push_back(torch::nn::ReLU());
  encoder->push_back(torch::nn::Conv2d(Conv2dOptions(ce, c.latent_dim, 1)));
  return encoder;
}

// model.encoder "cell_local": pixel unshuffle by the whole patch, then 1x1 convs only, so a
// token is a function of its own patch's pixels. A cell whose pixels do not change keeps its
// code whatever moves next to it: the tokens stop flickering, and a dynamics model sees change
// only where the frame changed (docs/tokenizer.md, "Cell-local encoder").
torch::nn::Sequential CellLocalEncoder(const ModelConfig& c) {
  using torch::nn::Conv2dOptions;
  const int64_t p = c.patch_size, ce = c.encoder_channels;
  torch::nn::Sequential encoder;
  encoder->push_back(SpaceToChannels(p));  // [B, 3p^2, h, w]
  encoder->push_back(torch::nn::Conv2d(Conv2dOptions(3 * p * p, ce, 1)));
  for (int i = 0; i < 2; ++i) {
    encoder->push_back(torch::nn::ReLU());
    encoder->push_back(torch::nn::Conv2d(Conv2dOptions(ce, ce, 1)));
  }
  encoder->push_back(torch::nn::ReLU());
  encoder->push_back(torch::nn::Conv2d(Conv2dOptions(ce, c.latent_dim, 1)));
  return encoder;
}

}  // namespace

VectorQuantizerImpl::VectorQuantizerImpl(QuantizerOptions options) : options(options) {
  torch::Tensor init = options.l2_normalize
                           ? torch::randn({options.num_codes, options.dim})
                           : torch::empty({options.num_codes, options.dim})
                                 .uniform_(-1.0 / options.num_codes, 1.0 / options.num_codes);
  codebook = register_parameter("codebook", init);
  steps_since_used =
      register_buffer("steps_since_used", torch::zeros({options.num_codes}, torch::kInt64));
  // Residual levels quantise differences of unit vectors, not directions: Euclidean lookup.
  QuantizerOptions level = options;
  level.l2_normalize = false;
  level.levels = 1;
  for (int64_t k = 1; k < options.levels; ++k) {
    residual.push_back(
        register_module("level" + std::to_string(k), std::make_shared<VectorQuantizerImpl>(level)));
  }
}

torch::Tensor VectorQuantizerImpl::Unit(const torch::Tensor& x) const {
  return options.l2_normalize ? F::normalize(x, F::NormalizeFuncOptions().dim(-1)) : x;
}

torch::Tensor VectorQuantizerImpl::Codes() const { return Unit(codebook); }

torch::Tensor VectorQuantizerImpl::Distances(const torch::Tensor& flat,
                                             const torch::Tensor& codes) {
  // ||z||^2 - 2 z.e + ||e||^2, without materialising [..., K, D].
  return flat.pow(2).sum(-1, true) - 2 * flat.matmul(codes.t()) + codes.pow(2).sum(1);
}

torch::Tensor VectorQuantizerImpl::NearestCodes(const torch::Tensor& flat,
                                                const torch::Tensor& codes) {
  if (!flat.device().is_cpu() || flat.scalar_type() != torch::kFloat) {
    return Distances(flat, codes).argmin(-1);
  }
  torch::NoGradGuard no_grad;
  // Distances()'s three terms from the same ATen calls (the matmul's sums are BLAS's, so they
  // must come from the same call shape); only the elementwise steps and the argmin are fused.
  const torch::Tensor zz = flat.pow(2).sum(-1).contiguous();      // [N]
  const torch::Tensor dot = flat.matmul(codes.t()).contiguous();  // [N, K]
  const torch::Tensor cc = codes.pow(2).sum(1).contiguous();      // [K]
  const int64_t N = dot.size(0), K = dot.size(1);
  torch::Tensor idx = torch::empty({N}, torch::kInt64);
  const float *zp = zz.data_ptr<float>(), *dp = dot.data_ptr<float>(), *cp = cc.data_ptr<float>();
  int64_t* out = idx.data_ptr<int64_t>();
  at::parallel_for(0, N, 64, [&](int64_t begin, int64_t end) {
    std::vector<float> row(static_cast<size_t>(K));
    for (int64_t n = begin; n < end; ++n) {
      const float* d = dp + n * K;
      // (zz - 2 dot) + cc, rounded after each step as Distances' sub and add; dot + dot is the
      // exact doubling of its `2 *` and leaves no product for the compiler to fuse.
      for (int64_t k = 0; k < K; ++k) row[k] = (zp[n] - (d[k] + d[k])) + cp[k];
      out[n] = FirstArgMin(row.data(), K);
    }
  });
  return idx;
}

VectorQuantizerImpl::Choices VectorQuantizerImpl::Choose(
    const torch::Tensor& flat, const std::function<void(int64_t, const torch::Tensor&)>& before) {
  Choices out;
  for (int64_t k = 0; k < levels(); ++k) {
    const torch::Tensor input = k == 0 ? flat.detach() : flat.detach() - out.total;
    if (before) before(k, input);
    const torch::Tensor codes = Level(k).Codes();
    torch::Tensor idx = NearestCodes(input, codes);
    torch::Tensor q = codes.index_select(0, idx);
    out.total = k == 0 ? q.detach() : out.total + q.detach();
    out.levels.push_back({input, idx, q});
  }
  return out;
}

QuantizerOutput VectorQuantizerImpl::forward(const torch::Tensor& z_e) {
  const int64_t B = z_e.size(0), D = z_e.size(1), h = z_e.size(2), w = z_e.size(3);
  const torch::Tensor flat = Unit(z_e.permute({0, 2, 3, 1}).reshape({-1, D}));  // [N, D]
  QuantizerOutput out;
  const Choices chosen = Choose(flat);
  for (const Choice& c : chosen.levels) {
    torch::Tensor loss = F::mse_loss(c.codes, c.input);  // VQ-VAE eq. 3, second term
    out.codebook_loss = out.codebook_loss.defined() ? out.codebook_loss + loss : loss;
    out.level_inputs.push_back(c.input);
    out.level_indices.push_back(c.indices);
  }
  const torch::Tensor& total = chosen.total;
  out.commitment = F::mse_loss(flat, total);          // VQ-VAE eq. 3, third term (x beta)
  torch::Tensor st = flat + (total - flat).detach();  // straight-through estimator
  out.z_q = st.view({B, h, w, D}).permute({0, 3, 1, 2}).contiguous();  // [B, D, h, w]
  out.indices = StackIndices(out.level_indices, B, h, w);
  const torch::Tensor& idx = out.level_indices[0];
  torch::Tensor counts = torch::bincount(idx, {}, options.num_codes).to(torch::kDouble);
  torch::Tensor p = counts / static_cast<double>(idx.size(0));
  out.perplexity = torch::exp(-(p * torch::log(p + 1e-10)).sum()).item<double>();
  out.usage = (counts > 0).sum().item<double>() / static_cast<double>(options.num_codes);
  return out;
}

torch::Tensor VectorQuantizerImpl::NearestIndices(const torch::Tensor& z_e) {
  const int64_t B = z_e.size(0), D = z_e.size(1), h = z_e.size(2), w = z_e.size(3);
  const torch::Tensor flat = Unit(z_e.permute({0, 2, 3, 1}).reshape({-1, D}));  // [N, D]
  std::vector<torch::Tensor> indices;
  for (const Choice& c : Choose(flat).levels) indices.push_back(c.indices);
  return StackIndices(indices, B, h, w);
}

torch::Tensor VectorQuantizerImpl::StickyIndices(const torch::Tensor& z_e, double margin) {
  TORCH_CHECK(residual.empty(), "code hysteresis needs one quantiser level");
  torch::NoGradGuard no_grad;
  const int64_t T = z_e.size(0), D = z_e.size(1), h = z_e.size(2), w = z_e.size(3);
  const torch::Tensor flat = Unit(z_e.permute({0, 2, 3, 1}).reshape({T, h * w, D}));
  const torch::Tensor dist = Distances(flat, Codes());  // forward()'s, per frame: [T, hw, K]
  torch::Tensor best = dist.argmin(2);                  // [T, hw]
  std::vector<torch::Tensor> kept = {best[0]};
  for (int64_t t = 1; t < T; ++t) {
    const torch::Tensor& prev = kept.back();
    torch::Tensor d_prev = dist[t].gather(1, prev.unsqueeze(1)).squeeze(1);
    torch::Tensor d_best = dist[t].gather(1, best[t].unsqueeze(1)).squeeze(1);
    kept.push_back(torch::where(d_prev <= d_best + margin, prev, best[t]));
  }
  return torch::stack(kept).view({T, h, w});
}

torch::Tensor VectorQuantizerImpl::Lookup(const torch::Tensor& indices) {
  const bool stacked = indices.dim() == 4;
  const int64_t B = indices.size(0), h = indices.size(-2), w = indices.size(-1);
  torch::Tensor total;  // [N, D]
  for (int64_t k = 0; k < (stacked ? indices.size(1) : 1); ++k) {
    const torch::Tensor level = stacked ? indices.select(1, k) : indices;
    torch::Tensor q = Level(k).Codes().index_select(0, level.flatten());
    total = total.defined() ? total + q : q;
  }
  return total.view({B, h, w, options.dim}).permute({0, 3, 1, 2}).contiguous();  // [B, D, h, w]
}

void VectorQuantizerImpl::SeedCodebook(const torch::Tensor& input, std::mt19937_64& rng) {
  std::vector<int64_t> src(static_cast<size_t>(options.num_codes));
  for (auto& s : src) s = static_cast<int64_t>(rng() % static_cast<uint64_t>(input.size(0)));
  torch::Tensor src_t = torch::tensor(src, torch::kInt64).to(codebook.device());
  codebook.copy_(input.index_select(0, src_t).to(codebook.dtype()));
}

void VectorQuantizerImpl::SeedFromLatents(const torch::Tensor& z_e, std::mt19937_64& rng) {
  torch::NoGradGuard no_grad;
  const torch::Tensor flat = Unit(z_e.permute({0, 2, 3, 1}).reshape({-1, options.dim}));
  Choose(flat, [&](int64_t k, const torch::Tensor& input) { Level(k).SeedCodebook(input, rng); });
}

int64_t VectorQuantizerImpl::ReseedDead(const torch::Tensor& indices, const torch::Tensor& inputs,
                                        int64_t dead_after, std::mt19937_64& rng) {
  torch::Tensor used = torch::bincount(indices, {}, options.num_codes) > 0;
  steps_since_used.add_(1).masked_fill_(used, 0);
  if (dead_after <= 0) return 0;
  torch::Tensor dead = (steps_since_used >= dead_after).nonzero().flatten().cpu();  // [n]
  const int64_t n = dead.size(0);
  if (n == 0) return 0;
  const uint64_t pool = static_cast<uint64_t>(inputs.size(0));
  std::vector<int64_t> src(n);
  for (auto& s : src) s = static_cast<int64_t>(rng() % pool);
  torch::Tensor src_t = torch::tensor(src, torch::kInt64).to(codebook.device());
  torch::Tensor dead_t = dead.to(codebook.device());
  codebook.index_copy_(0, dead_t, inputs.index_select(0, src_t).to(codebook.dtype()));
  steps_since_used.index_fill_(0, dead_t, 0);
  return n;
}

int64_t VectorQuantizerImpl::UpdateUsageAndReseed(const QuantizerOutput& out, int64_t dead_after,
                                                  std::mt19937_64& rng) {
  torch::NoGradGuard no_grad;
  int64_t reseeded = 0;
  for (int64_t k = 0; k < levels(); ++k) {
    reseeded += Level(k).ReseedDead(out.level_indices[k], out.level_inputs[k], dead_after, rng);
  }
  return reseeded;
}

torch::Tensor CellCodes(const torch::Tensor& indices) {
  if (indices.dim() == 3) return indices;
  const int64_t T = indices.size(0), L = indices.size(1), h = indices.size(2), w = indices.size(3);
  torch::Tensor tuples = indices.permute({0, 2, 3, 1}).reshape({-1, L});
  return std::get<1>(at::unique_dim(tuples, 0, /*sorted=*/true, /*return_inverse=*/true))
      .view({T, h, w});
}

torch::Tensor MoveByFlow(const torch::Tensor& images, const torch::Tensor& flow) {
  const int64_t B = images.size(0), S = images.size(-1);
  // The flow is in pixels; grid_sample's coordinates span the frame as [-1, 1].
  torch::Tensor offset = F::interpolate(flow, F::InterpolateFuncOptions()
                                                  .size(std::vector<int64_t>{S, S})
                                                  .mode(torch::kBilinear)
                                                  .align_corners(false))
                             .permute({0, 2, 3, 1}) *
                         (2.0 / S);
  torch::Tensor identity = torch::eye(2, 3, images.options()).expand({B, 2, 3});
  torch::Tensor grid = F::affine_grid(identity, {B, 3, S, S}, /*align_corners=*/false);
  return F::grid_sample(images, grid + offset,
                        F::GridSampleFuncOptions()
                            .mode(torch::kBilinear)
                            .padding_mode(torch::kBorder)
                            .align_corners(false));
}

torch::Tensor ChangedPixels(const torch::Tensor& images, const torch::Tensor& anchors) {
  torch::NoGradGuard no_grad;
  torch::Tensor changed = ((images - anchors).abs().amax(1, /*keepdim=*/true) > 30.0 / 127.5);
  // A blank anchor (zeros, mid-grey) is no anchor: nothing "changed" against it.
  torch::Tensor real = anchors.abs().amax({1, 2, 3}, /*keepdim=*/true) > 0;
  return (changed & real).to(images.dtype());
}

torch::Tensor DetailWeight(const torch::Tensor& images, double alpha) {
  torch::NoGradGuard no_grad;
  torch::Tensor blur = F::avg_pool2d(
      images, F::AvgPool2dFuncOptions(7).stride(1).padding(3).count_include_pad(false));
  torch::Tensor d = (images - blur).abs().amax(1, /*keepdim=*/true);  // [B, 1, H, W]
  return 1 + alpha * (d / 0.25).clamp_max(1);
}

VqVaeImpl::VqVaeImpl(const ModelConfig& c) : config(c) {
  using torch::nn::Conv2dOptions;
  using torch::nn::ConvTranspose2dOptions;
  const int f = c.stem_factor, downs = Log2(c.patch_size / f);
  const int64_t d = c.latent_dim, pixels = 3 * f * f;
  const int64_t cd = c.decoder_channels;
  encoder = c.encoder == "cell_local" ? CellLocalEncoder(c) : ConvEncoder(c);

  decoder = torch::nn::Sequential(torch::nn::Conv2d(Conv2dOptions(d, cd, 3).padding(1)));
  for (int i = 0; i < c.decoder_layers; ++i) decoder->push_back(ResBlock(cd));
  for (int level = 0; level < downs; ++level) {
    decoder->push_back(torch::nn::ReLU());
    decoder->push_back(torch::nn::ConvTranspose2d(
        ConvTranspose2dOptions(Width(c, cd, level), Width(c, cd, level + 1), 4)
            .stride(2)
            .padding(1)));
  }  // [B, Cd(downs), H/f, W/f]
  const int64_t top = Width(c, cd, downs);
  // The pixel head; anchor-decoded frames are the anchor plus its output (unshuffled).
  auto pixel_head = [&](torch::nn::Sequential& seq) {
    seq->push_back(torch::nn::ReLU());
    seq->push_back(torch::nn::Conv2d(Conv2dOptions(top, pixels, 3).padding(1)));
  };
  if (!c.anchor_decoder) {
    pixel_head(decoder);
    if (f > 1) decoder->push_back(ChannelsToSpace(f));  // [B, 3, H, W]
  }
  register_module("encoder", encoder);
  register_module("decoder", decoder);
  if (c.anchor_decoder) {
    anchor_stem = torch::nn::Sequential();
    if (f > 1) anchor_stem->push_back(SpaceToChannels(f));
    anchor_stem->push_back(torch::nn::Conv2d(Conv2dOptions(pixels, top, 3).padding(1)));
    // One push_back per layer: constructor arguments are evaluated in no fixed order, and the
    // layers must draw their initial weights in this order (the twin's).
    merge = torch::nn::Sequential(torch::nn::ReLU());
    merge->push_back(torch::nn::Conv2d(Conv2dOptions(2 * top, top, 3).padding(1)));
    merge->push_back(ResBlock(top));
    head = torch::nn::Sequential();
    pixel_head(head);
    // Zero-initialised correction: at step 0 every decoded frame is its anchor.
    auto* last = head->ptr(1)->as<torch::nn::Conv2dImpl>();
    torch::NoGradGuard no_grad;
    last->weight.zero_();
    last->bias.zero_();
    register_module("anchor_stem", anchor_stem);
    register_module("merge", merge);
    register_module("head", head);
  }
  quantizer =
      register_module("quantizer", VectorQuantizer(QuantizerOptions{.num_codes = c.num_codes,
                                                                    .dim = c.latent_dim,
                                                                    .l2_normalize = c.l2_normalize,
                                                                    .beta = c.beta,
                                                                    .levels = c.levels}));
  if (c.anchor_flow) {  // created last: the other layers draw the weights they drew without it
    anchor_flow =
        register_module("anchor_flow", torch::nn::Conv2d(Conv2dOptions(top, 2, 3).padding(1)));
    torch::NoGradGuard no_grad;  // zero flow at step 0: the anchor decoder without it
    anchor_flow->weight.zero_();
    anchor_flow->bias.zero_();
  }
}

torch::Tensor VqVaeImpl::Encode(const torch::Tensor& images) { return encoder->forward(images); }

torch::Tensor VqVaeImpl::Decode(const torch::Tensor& z_q, const torch::Tensor& anchors) {
  if (!config.anchor_decoder) return decoder->forward(z_q);
  const int64_t f = config.stem_factor, S = config.image_size;
  torch::Tensor anchor =
      anchors.defined() ? anchors : torch::zeros({z_q.size(0), 3, S, S}, z_q.options());
  torch::Tensor h =
      merge->forward(torch::cat({decoder->forward(z_q), anchor_stem->forward(anchor)}, 1));
  if (anchor_flow) anchor = MoveByFlow(anchor, anchor_flow->forward(h));
  torch::Tensor base = f > 1 ? PixelUnshuffle(anchor, f) : anchor;
  torch::Tensor y = head->forward(h) + base;  // [B, 3f^2, H/f, W/f]
  return f > 1 ? PixelShuffle(y, f) : y;
}

VqVaeOutput VqVaeImpl::forward(const torch::Tensor& images, const torch::Tensor& anchors) {
  VqVaeOutput out;
  out.quant = quantizer->forward(Encode(images));       // z_q: [B, D, h, w]
  out.reconstruction = Decode(out.quant.z_q, anchors);  // [B, 3, H, W]
  torch::Tensor error = (out.reconstruction - images).abs();
  out.recon_l1 = error.mean();
  torch::Tensor recon = out.recon_l1;
  const bool changes = config.change_weight > 0 && anchors.defined();
  if (config.detail_weight > 0 || changes) {
    // Normalised by the mean weight so the loss keeps L1's scale (and the lr its meaning).
    torch::Tensor w = DetailWeight(images, config.detail_weight);
    if (changes) w = w + config.change_weight * ChangedPixels(images, anchors);
    recon = (w * error).mean() / w.mean();
  }
  out.loss = recon + out.quant.codebook_loss + config.beta * out.quant.commitment;
  return out;
}

}  // namespace wm::tokenize

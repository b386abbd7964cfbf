#pragma once
// The VQ-VAE image tokenizer in LibTorch: conv encoder -> latent -> nearest-code quantisation
// (straight-through) -> conv decoder. Internal header (includes torch); tools and other stages
// use tokenize/trainer.h.
#include <torch/torch.h>

#include <functional>
#include <memory>
#include <random>
#include <vector>

#include "tokenize/config.h"

namespace wm::tokenize {

struct QuantizerOptions {
  int64_t num_codes = 1024;
  int64_t dim = 32;
  bool l2_normalize = true;  // cosine lookup; quantised vectors are unit codes
  double beta = 0.25;
  // Residual VQ (SoundStream, RQ-VAE; model.levels): level 0 as above, each further level a
  // Euclidean codebook of num_codes on what the levels before left of the (unit) latent.
  int64_t levels = 1;
};

struct QuantizerOutput {
  torch::Tensor z_q;            // [B, D, h, w] straight-through: forward = the levels' codes
                                // summed, grad -> z_e
  torch::Tensor indices;        // [B, h, w] int64; [B, levels, h, w] with residual levels
  torch::Tensor codebook_loss;  // sum over levels of ||sg(level input) - e||^2 (mean)
  torch::Tensor commitment;     // ||z_e - sg(codes summed)||^2 (mean), weighted by beta
  // Per level: what it quantised [B*h*w, D] (detached; level 0: the latents, normalised if
  // l2_normalize; level k: their residual after levels 0..k-1) and its choices [B*h*w], for
  // the dead-code re-seeding of each codebook.
  std::vector<torch::Tensor> level_inputs, level_indices;
  double perplexity = 0;  // exp(entropy of the batch's level-0 code histogram)
  double usage = 0;       // fraction of level 0's codes used in the batch
};

struct VectorQuantizerImpl : torch::nn::Module {
  explicit VectorQuantizerImpl(QuantizerOptions options);
  QuantizerOutput forward(const torch::Tensor& z_e);  // z_e: [B, D, h, w]
  // [B, h, w] (or [B, levels, h, w]) -> [B, D, h, w]: the levels' codes summed.
  torch::Tensor Lookup(const torch::Tensor& indices);
  // forward()'s indices alone, without its losses, straight-through output and code
  // statistics: what encoding needs.
  torch::Tensor NearestIndices(const torch::Tensor& z_e);
  // Codes of consecutive frames z_e [T, D, h, w] with hysteresis: a cell keeps the previous
  // frame's code while that code is within `margin` of the nearest one (in the lookup's squared
  // distance; cosine lookup: 2 - 2 cos), so near-synonym codes stop flipping on unchanged
  // cells. margin 0 = forward()'s indices. -> [T, h, w] int64. One level only.
  torch::Tensor StickyIndices(const torch::Tensor& z_e, double margin);

  // Dead-code handling, per level: codes not chosen for `dead_after` consecutive steps are
  // replaced by that level's inputs drawn (with `rng`) from this batch. Returns how many codes
  // were re-seeded.
  int64_t UpdateUsageAndReseed(const QuantizerOutput& out, int64_t dead_after,
                               std::mt19937_64& rng);
  // Data-dependent init: every code becomes an encoder output drawn (with `rng`) from
  // `z_e` [B, D, h, w], so training starts with a codebook that covers the data instead of
  // collapsing onto a few codes for the first hundred steps; each residual level then from
  // the residuals that the seeded levels before it leave.
  void SeedFromLatents(const torch::Tensor& z_e, std::mt19937_64& rng);

  int64_t levels() const { return 1 + static_cast<int64_t>(residual.size()); }

  // `x` [..., D] as the lookup compares it: unit vectors with l2_normalize, else unchanged.
  torch::Tensor Unit(const torch::Tensor& x) const;
  torch::Tensor Codes() const;  // Unit(codebook)
  // Squared distances [..., K] from latents `flat` [..., D] to `codes` [K, D].
  static torch::Tensor Distances(const torch::Tensor& flat, const torch::Tensor& codes);
  // Distances(flat, codes).argmin(-1) for flat [N, D] -> [N] int64, bit for bit (same float
  // roundings, first index on ties, first NaN wins), without the four [N, K] temporaries.
  static torch::Tensor NearestCodes(const torch::Tensor& flat, const torch::Tensor& codes);

  QuantizerOptions options;
  torch::Tensor codebook;          // [K, D] parameter
  torch::Tensor steps_since_used;  // [K] int64 buffer (checkpointed)
  // Levels 1.. of residual VQ, submodules "level1", "level2", ... (one level: none, so a
  // one-level checkpoint's names are unchanged).
  std::vector<std::shared_ptr<VectorQuantizerImpl>> residual;

 private:
  VectorQuantizerImpl& Level(int64_t k) { return k == 0 ? *this : *residual[k - 1]; }
  // Each level's nearest codes for `flat` [N, D] (unit latents): level k quantises the flat
  // latents minus the codes levels 0..k-1 chose. `before(k, input)` runs first (re-seeding).
  struct Choice {
    torch::Tensor input, indices, codes;  // [N, D] detached, [N], [N, D] (with grad)
  };
  struct Choices {
    std::vector<Choice> levels;
    torch::Tensor total;  // [N, D]: the chosen codes summed over the levels, no gradient
  };
  Choices Choose(const torch::Tensor& flat,
                 const std::function<void(int64_t, const torch::Tensor&)>& before = nullptr);
  void SeedCodebook(const torch::Tensor& input, std::mt19937_64& rng);
  int64_t ReseedDead(const torch::Tensor& indices, const torch::Tensor& inputs, int64_t dead_after,
                     std::mt19937_64& rng);
};
TORCH_MODULE(VectorQuantizer);

// Indices [T, h, w] as they are, or [T, levels, h, w] -> [T, h, w] int64 where two cells are
// equal when all their levels' codes are: one code per cell, for counting flicker.
torch::Tensor CellCodes(const torch::Tensor& indices);

struct VqVaeOutput {
  torch::Tensor reconstruction;  // [B, 3, H, W] in [-1, 1] (not clamped)
  QuantizerOutput quant;
  torch::Tensor recon_l1;  // mean |recon - image| (unweighted: what metrics.csv logs)
  torch::Tensor loss;      // recon + codebook + beta * commitment, recon = recon_l1 or,
                           // with model.detail_weight, the detail-weighted L1
};

// Per-pixel reconstruction weight [B, 1, H, W] for model.detail_weight = alpha > 0:
// 1 + alpha * min(1, d / 0.25), d = max over channels of |image - 7x7 box blur of image|
// (0.25 in [-1, 1] units is 32 levels). A small object differs from its blur over its whole
// area, the flat table not at all, so a 3-4 pixel block is not drowned by the table without any
// segmentation label. A function of the input only: no gradient flows through it.
torch::Tensor DetailWeight(const torch::Tensor& images, double alpha);

// [B, 1, H, W] 1 where a channel of `images` differs from its anchor by over 30 levels, 0 where
// not and wherever the anchor is blank (all zeros): model.change_weight's extra L1 weight on
// what the tokens must draw, since the anchor gives the rest. No gradient flows through it.
torch::Tensor ChangedPixels(const torch::Tensor& images, const torch::Tensor& anchors);

// `images` [B, 3, S, S] resampled (bilinear, border) at each pixel's position plus `flow`
// [B, 2, h, w] (x, y offsets in pixels, upsampled bilinearly to S x S): model.anchor_flow.
torch::Tensor MoveByFlow(const torch::Tensor& images, const torch::Tensor& flow);

// With model.anchor_decoder the decoder also reads an anchor frame (an earlier real frame of
// the episode, or zeros: "no anchor"). Its features join the tokens' at the stem resolution, and
// the output is the anchor plus a correction whose last layer starts at zero, so an untrained
// decoder copies the anchor. Training blanks the anchor often (train.anchor_dropout), so the
// tokens keep describing the whole frame; the anchor restores what they lose (a 3-pixel block).
struct VqVaeImpl : torch::nn::Module {
  explicit VqVaeImpl(const ModelConfig& config);
  // images: [B, 3, H, W] in [-1, 1]; anchors: the same shape, or undefined (no anchor).
  VqVaeOutput forward(const torch::Tensor& images, const torch::Tensor& anchors = {});
  torch::Tensor Encode(const torch::Tensor& images);  // -> [B, D, h, w] pre-quantisation
  // [B, D, h, w] -> [B, 3, H, W]; `anchors` as in forward (ignored without anchor_decoder).
  torch::Tensor Decode(const torch::Tensor& z_q, const torch::Tensor& anchors = {});

  ModelConfig config;
  torch::nn::Sequential encoder{nullptr}, decoder{nullptr};
  // Only with anchor_decoder (else `decoder` ends with the pixel head): anchor -> features at
  // the stem resolution; [tokens' features, anchor's] -> features; features -> pixels.
  torch::nn::Sequential anchor_stem{nullptr}, merge{nullptr}, head{nullptr};
  VectorQuantizer quantizer{nullptr};
  // Only with anchor_flow: merged features -> the anchor's flow in pixels [B, 2, H/f, W/f],
  // zero-initialised, so the anchor starts unmoved; it lets the decoder move what the anchor
  // shows (the arm, a carried block) instead of redrawing it from the codes.
  torch::nn::Conv2d anchor_flow{nullptr};
};
TORCH_MODULE(VqVae);

}  // namespace wm::tokenize

// VectorQuantizer and VqVae: nearest-code choice, straight-through gradients, loss values,
// dead-code re-seeding, and the presets building a model of the right shape.
#include <gtest/gtest.h>

#include <cmath>

#include "tests/core/test_util.h"
#include "tokenize/vqvae.h"

namespace wm::tokenize {
namespace {

// Four codes on the axes of R^2; two latents in a [1, 2, 1, 2] map.
VectorQuantizer AxisQuantizer(bool l2_normalize) {
  VectorQuantizer q(QuantizerOptions{.num_codes = 4, .dim = 2, .l2_normalize = l2_normalize});
  torch::NoGradGuard no_grad;
  q->codebook.copy_(torch::tensor({1.f, 0.f, 0.f, 1.f, -1.f, 0.f, 0.f, -1.f}).view({4, 2}));
  return q;
}

torch::Tensor Latents(std::vector<float> xy) {  // [(x0, y0), (x1, y1)] -> [1, 2, 1, 2]
  return torch::tensor(xy).view({1, 2, 2}).permute({2, 0, 1}).unsqueeze(0).contiguous();
}

TEST(Quantizer, PicksNearestCodeAndPassesGradientsStraightThrough) {
  VectorQuantizer q = AxisQuantizer(false);
  torch::Tensor z = Latents({0.9f, 0.2f, -0.1f, -2.f}).requires_grad_(true);  // [1, 2, 1, 2]
  QuantizerOutput out = q->forward(z);
  EXPECT_EQ(out.indices.flatten()[0].item<int64_t>(), 0);
  EXPECT_EQ(out.indices.flatten()[1].item<int64_t>(), 3);
  EXPECT_TRUE(torch::allclose(out.z_q, Latents({1.f, 0.f, 0.f, -1.f})));
  // mean over 4 elements of (0.1^2 + 0.2^2 + 0.1^2 + 1^2)
  EXPECT_NEAR(out.codebook_loss.item<double>(), 1.06 / 4, 1e-6);
  EXPECT_NEAR(out.commitment.item<double>(), 1.06 / 4, 1e-6);
  EXPECT_NEAR(out.usage, 0.5, 1e-12);
  EXPECT_NEAR(out.perplexity, 2.0, 1e-6);
  (out.z_q * torch::tensor({1.f, 2.f}).view({1, 2, 1, 1})).sum().backward();
  // d(z_q)/d(z_e) = identity: the gradient reaches z_e unchanged, per channel 1 and 2.
  EXPECT_TRUE(torch::allclose(z.grad(), torch::tensor({1.f, 1.f, 2.f, 2.f}).view({1, 2, 1, 2})));
  EXPECT_FALSE(q->codebook.grad().defined() && q->codebook.grad().abs().sum().item<float>() > 0);
}

TEST(Quantizer, CommitmentAndCodebookLossesTrainTheirOwnSide) {
  VectorQuantizer q = AxisQuantizer(false);
  torch::Tensor z = Latents({0.9f, 0.2f, -0.1f, -2.f}).requires_grad_(true);
  QuantizerOutput out = q->forward(z);
  out.codebook_loss.backward();
  EXPECT_FALSE(z.grad().defined());  // the codebook loss only moves codes
  EXPECT_GT(q->codebook.grad().abs().sum().item<float>(), 0);
}

// model.levels 2: level 1 (Euclidean) quantises what level 0 left; the decoder reads the sum.
TEST(Quantizer, ResidualLevelQuantisesWhatTheFirstLeft) {
  VectorQuantizer q(QuantizerOptions{.num_codes = 4, .dim = 2, .l2_normalize = false, .levels = 2});
  {
    torch::NoGradGuard no_grad;
    q->codebook.copy_(torch::tensor({1.f, 0.f, 0.f, 1.f, -1.f, 0.f, 0.f, -1.f}).view({4, 2}));
    q->residual[0]->codebook.copy_(
        torch::tensor({0.f, 0.f, 0.1f, 0.2f, -0.1f, -0.1f, 0.f, -1.f}).view({4, 2}));
  }
  ASSERT_EQ(q->levels(), 2);
  EXPECT_FALSE(q->residual[0]->options.l2_normalize);
  torch::Tensor z = Latents({0.9f, 0.2f, -0.1f, -2.f}).requires_grad_(true);
  QuantizerOutput out = q->forward(z);
  // Latent 0 (0.9, 0.2): level 0 (1, 0), residual (-0.1, 0.2) -> level-1 code 1 (0.1, 0.2) at
  // squared distance 0.04 (code 0 at 0.05, code 2 at 0.09). Latent 1 (-0.1, -2): level 0
  // (0, -1), residual (-0.1, -1) -> code 3 (0, -1) at 0.01.
  EXPECT_EQ(out.indices.sizes(), (std::vector<int64_t>{1, 2, 1, 2}));
  EXPECT_EQ(out.indices[0][0].flatten()[0].item<int64_t>(), 0);
  EXPECT_EQ(out.indices[0][0].flatten()[1].item<int64_t>(), 3);
  EXPECT_EQ(out.indices[0][1].flatten()[0].item<int64_t>(), 1);
  EXPECT_EQ(out.indices[0][1].flatten()[1].item<int64_t>(), 3);
  const torch::Tensor sum = Latents({1.1f, 0.2f, 0.f, -2.f});
  EXPECT_TRUE(torch::allclose(out.z_q, sum));
  EXPECT_TRUE(torch::allclose(q->Lookup(out.indices), sum));
  EXPECT_TRUE(torch::equal(q->NearestIndices(z), out.indices));
  // ||z - sum||^2: (0.2^2 + 0 + 0.1^2 + 0) / 4; level losses: level 0's 1.06 / 4, level 1's
  // ((-0.2)^2 + 0 + 0.1^2 + 0) / 4.
  EXPECT_NEAR(out.commitment.item<double>(), 0.05 / 4, 1e-6);
  EXPECT_NEAR(out.codebook_loss.item<double>(), (1.06 + 0.05) / 4, 1e-6);
  ASSERT_EQ(out.level_inputs.size(), 2u);
  EXPECT_TRUE(
      torch::allclose(out.level_inputs[1], torch::tensor({-0.1f, 0.2f, -0.1f, -1.f}).view({2, 2})));
  EXPECT_TRUE(torch::equal(CellCodes(out.indices), torch::tensor({0, 1}).view({1, 1, 2})));
}

TEST(Quantizer, L2NormalisedLookupUsesDirectionNotLength) {
  VectorQuantizer q = AxisQuantizer(true);
  // (5, 0.1) is far from code 0 in Euclidean terms but points the same way.
  QuantizerOutput out = q->forward(Latents({5.f, 0.1f, -3.f, 0.5f}));
  EXPECT_EQ(out.indices.flatten()[0].item<int64_t>(), 0);
  EXPECT_EQ(out.indices.flatten()[1].item<int64_t>(), 2);
  EXPECT_NEAR(out.z_q.flatten()[0].item<float>(), 1.f, 1e-6);
}

// NearestCodes must equal argmin over the materialised Distances bit for bit, ties and NaN
// included: encoded tokens are compared byte for byte with the PyTorch twin's.
TEST(Quantizer, NearestCodesEqualsArgminOfDistancesIncludingTiesAndNaN) {
  torch::manual_seed(3);
  // Coarse values (multiples of 1/4) and repeated codes make many exactly equal distances.
  torch::Tensor codes = (torch::randn({96, 8}) * 4).round() / 4;
  codes = torch::cat({codes, codes.slice(0, 0, 32), codes.slice(0, 10, 12)});  // [130, 8]
  torch::Tensor flat =
      torch::cat({(torch::randn({700, 8}) * 4).round() / 4, codes, torch::randn({300, 8})});
  namespace F = torch::nn::functional;
  for (const torch::Tensor& c : {codes, F::normalize(codes)}) {  // Euclidean and cosine lookup
    for (const torch::Tensor& z : {flat, F::normalize(flat)}) {
      EXPECT_TRUE(torch::equal(VectorQuantizerImpl::NearestCodes(z, c),
                               VectorQuantizerImpl::Distances(z, c).argmin(-1)));
    }
  }
  flat[5][2] = std::nanf("");    // a NaN latent: all its distances NaN -> code 0
  codes[40][0] = std::nanf("");  // a NaN code: every latent's first NaN distance wins
  for (const torch::Tensor& c : {codes.slice(0, 0, 40), codes}) {
    torch::Tensor expected = VectorQuantizerImpl::Distances(flat, c).argmin(-1);
    EXPECT_TRUE(torch::equal(VectorQuantizerImpl::NearestCodes(flat, c), expected));
  }
  EXPECT_EQ(VectorQuantizerImpl::NearestCodes(flat, codes)[0].item<int64_t>(), 40);
  torch::Tensor tail = codes.slice(0, 41).clone();  // 89 codes: the last one in the scan's tail
  tail[88][1] = std::nanf("");
  EXPECT_TRUE(torch::equal(VectorQuantizerImpl::NearestCodes(flat, tail),
                           VectorQuantizerImpl::Distances(flat, tail).argmin(-1)));
}

TEST(Quantizer, ReseedsCodesUnusedForLongEnoughFromBatchLatents) {
  VectorQuantizer q = AxisQuantizer(false);
  std::mt19937_64 rng(7);
  QuantizerOutput out = q->forward(Latents({0.9f, 0.2f, 0.8f, 0.1f}));  // both pick code 0
  EXPECT_EQ(q->UpdateUsageAndReseed(out, /*dead_after=*/2, rng), 0);
  EXPECT_EQ(q->steps_since_used[1].item<int64_t>(), 1);
  EXPECT_EQ(q->UpdateUsageAndReseed(out, 2, rng), 3);  // codes 1, 2, 3 reached 2 steps
  EXPECT_TRUE(torch::allclose(q->codebook[0], torch::tensor({1.f, 0.f})));
  for (int k = 1; k < 4; ++k) {
    torch::Tensor row = q->codebook[k];
    const bool from_batch = torch::allclose(row, torch::tensor({0.9f, 0.2f})) ||
                            torch::allclose(row, torch::tensor({0.8f, 0.1f}));
    EXPECT_TRUE(from_batch) << "code " << k;
    EXPECT_EQ(q->steps_since_used[k].item<int64_t>(), 0);
  }
}

TEST(VqVae, Meta64PresetBuildsAndMapsFramesToTokens) {
  TokenizerConfig c = LoadTokenizerConfig(test::SourceDir() + "/configs/tokenizer/meta64.yaml");
  torch::manual_seed(0);
  VqVae model(c.model);
  torch::NoGradGuard no_grad;
  VqVaeOutput out = model->forward(torch::zeros({1, 3, 64, 64}));
  EXPECT_EQ(out.quant.indices.sizes(), (std::vector<int64_t>{1, 16, 16}));  // patch 4
  EXPECT_EQ(out.reconstruction.sizes(), (std::vector<int64_t>{1, 3, 64, 64}));
  EXPECT_EQ(model->quantizer->codebook.sizes(), (std::vector<int64_t>{1024, 32}));
}

// By hand: a flow of exactly (+1, 0) pixels samples each pixel's right neighbour (the last
// column repeats: border padding), and a zero flow returns the image.
TEST(VqVae, AnchorFlowMovesByWholePixels) {
  torch::Tensor image = torch::arange(3 * 8 * 8, torch::kFloat).view({1, 3, 8, 8}) / 192.0;
  torch::Tensor right = torch::zeros({1, 2, 2, 2});
  right.select(1, 0).fill_(1.0);  // x offset 1, y offset 0, everywhere (upsampled: constant)
  torch::Tensor expected = torch::cat({image.narrow(3, 1, 7), image.narrow(3, 7, 1)}, 3);
  EXPECT_LT((MoveByFlow(image, right) - expected).abs().max().item<float>(), 1e-6);
  EXPECT_LT((MoveByFlow(image, torch::zeros({1, 2, 2, 2})) - image).abs().max().item<float>(),
            1e-6);
}

// 31 levels of change counts, 29 do not (in any one channel); a blank anchor marks nothing.
TEST(VqVae, ChangedPixelsAreThoseMovedOverThirtyLevelsSinceARealAnchor) {
  torch::Tensor anchor = torch::full({2, 3, 1, 3}, 0.1f);
  torch::Tensor frame = anchor.clone();
  frame[0][1][0][0] += 31 / 127.5;
  frame[0][2][0][1] -= 29 / 127.5;
  frame[1][0][0][2] += 100 / 127.5;
  anchor[1].zero_();  // the second frame's anchor is blank
  torch::Tensor changed = ChangedPixels(frame, anchor);
  EXPECT_EQ(changed.sizes(), (std::vector<int64_t>{2, 1, 1, 3}));
  torch::Tensor flat = changed.flatten().contiguous();
  EXPECT_EQ(std::vector<float>(flat.data_ptr<float>(), flat.data_ptr<float>() + flat.numel()),
            (std::vector<float>{1, 0, 0, 0, 0, 0}));
}

TEST(VqVae, TinyPresetGivesEightByEightTokens) {
  TokenizerConfig c = LoadTokenizerConfig(test::SourceDir() + "/configs/tokenizer/tiny.yaml");
  VqVae model(c.model);
  torch::NoGradGuard no_grad;
  VqVaeOutput out = model->forward(torch::zeros({2, 3, 64, 64}));
  EXPECT_EQ(out.quant.indices.sizes(), (std::vector<int64_t>{2, 8, 8}));
  EXPECT_EQ(out.reconstruction.sizes(), (std::vector<int64_t>{2, 3, 64, 64}));
}

// model.encoder cell_local: a token is a function of its own 8x8 patch. Repainting one patch
// changes that cell's latent and no other; the conv encoder's receptive field spills over.
TEST(VqVae, CellLocalEncoderKeepsEveryOtherCellsLatent) {
  TokenizerConfig c = LoadTokenizerConfig(test::SourceDir() + "/configs/tokenizer/stable64.yaml");
  ASSERT_EQ(c.model.encoder, "cell_local");
  auto changed_cells = [](const ModelConfig& model_config) {
    torch::manual_seed(1);
    VqVae model(model_config);
    torch::NoGradGuard no_grad;
    torch::Tensor frame = torch::rand({1, 3, 64, 64}) * 2 - 1;
    torch::Tensor painted = frame.clone();
    painted.narrow(2, 24, 8).narrow(3, 16, 8).fill_(0.9);  // the patch of cell (3, 2)
    torch::Tensor moved = (model->Encode(painted) - model->Encode(frame)).abs().amax(1)[0] > 0;
    return moved;
  };
  torch::Tensor local = changed_cells(c.model);
  EXPECT_EQ(local.sizes(), (std::vector<int64_t>{8, 8}));
  EXPECT_TRUE(local[3][2].item<bool>());
  EXPECT_EQ(local.sum().item<int64_t>(), 1);
  ModelConfig conv = c.model;
  conv.encoder = "conv";
  EXPECT_GT(changed_cells(conv).sum().item<int64_t>(), 1);
}

}  // namespace
}  // namespace wm::tokenize

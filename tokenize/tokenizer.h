#pragma once
// A trained tokenizer loaded from its checkpoint: frames -> codes -> frames. Torch-free
// interface (the model lives behind a pimpl), used by `wm-tokenize encode/decode`, the
// dynamics model's evaluation and the lpips_style / fvd_style metrics.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "tokenize/config.h"

namespace wm::tokenize {

// One encoder activation map, [n, channels, height, width] row-major.
struct FeatureMap {
  std::vector<int64_t> shape;
  std::vector<float> values;
};

class Tokenizer {
 public:
  // `checkpoint`: a run directory or its checkpoint.wmt. `device`: "cpu", "cuda", "cuda:N".
  // Throws wm::Error naming the file when it is missing, corrupt or not a tokenizer.
  explicit Tokenizer(const std::string& checkpoint, const std::string& device = "cpu");
  ~Tokenizer();
  Tokenizer(const Tokenizer&) = delete;
  Tokenizer& operator=(const Tokenizer&) = delete;

  const TokenizerConfig& config() const;
  const std::string& checkpoint_path() const;    // the .wmt file
  const std::string& checkpoint_sha256() const;  // of the .wmt file
  const std::string& config_hash() const;
  int image_size() const { return config().model.image_size; }
  int grid() const { return config().model.image_size / config().model.patch_size; }
  // Codes per cell (model.levels): a frame's codes are [levels, g, g], level-major.
  int levels() const { return config().model.levels; }
  int64_t tokens_per_frame() const { return int64_t{levels()} * grid() * grid(); }

  // Whether the decoder reads an anchor frame (model.anchor_decoder): frames are then decoded
  // from their tokens and an earlier real frame of the episode (docs/tokenizer.md).
  bool anchored() const { return config().model.anchor_decoder; }

  // frames: [n, 3, S, S] planar RGB floats in [-1, 1] (tokenize::DecodeFrame's layout).
  std::vector<uint32_t> Encode(const float* frames, int64_t n) const;  // -> [n, levels, g, g]
  // The n frames of one episode, in order, with code hysteresis `margin`
  // (VectorQuantizer::StickyIndices; 0 = Encode): what `wm-tokenize encode --hysteresis` stores.
  // margin > 0 needs one level (throws wm::Error naming the checkpoint otherwise).
  std::vector<uint32_t> EncodeEpisode(const float* frames, int64_t n, double margin) const;
  // codes [n, levels, g, g] -> [n, 3, S, S]. `anchors`: [n, 3, S, S] like frames, one per
  // decoded frame, or null (no anchor: what an anchored tokenizer's tokens say alone). Ignored
  // unless anchored().
  std::vector<float> Decode(const uint32_t* codes, int64_t n, const float* anchors = nullptr) const;
  // Decode(Encode(frames), anchors), clamped to [-1, 1] like Decode.
  std::vector<float> Reconstruct(const float* frames, int64_t n,
                                 const float* anchors = nullptr) const;
  // The encoder's activations after each non-linearity (and the pre-quantisation latent),
  // shallow to deep: the feature stack of the lpips_style / fvd_style metrics.
  std::vector<FeatureMap> EncoderFeatures(const float* frames, int64_t n) const;

  // lpips_style (docs/metrics.md): LPIPS's distance over this encoder's features instead of
  // AlexNet's — per layer, features unit-normalised over channels, squared difference summed
  // over channels, averaged over space; summed over layers (LPIPS with all "lin" weights 1).
  // One value per frame pair; a and b are [n, 3, S, S] like Encode's input.
  std::vector<double> PerceptualDistance(const float* a, const float* b, int64_t n) const;
  // Per frame, every EncoderFeatures layer averaged over space and concatenated: [n, dim]
  // (the frame descriptor of fvd_style clips). Returns dim through `dim`.
  std::vector<double> FrameDescriptors(const float* frames, int64_t n, int64_t* dim) const;
  // fvd_style clip descriptor: the mean and the standard deviation over the clip's n frames of
  // FrameDescriptors, concatenated ([2 * dim]).
  std::vector<double> ClipDescriptor(const float* frames, int64_t n) const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// Planar [3, S, S] floats in [-1, 1] -> interleaved RGB uint8 [S, S, 3] (rounded, clamped).
std::vector<uint8_t> PlanarToRgb8(const float* planar, int size);

}  // namespace wm::tokenize

#include "evaluate/clip_decode.h"

#include "core/episode.h"
#include "tokenize/frame_sampler.h"
#include "tokenize/tokenizer.h"

namespace wm::evaluate {

Clip RealClip(const Episode& ep, const std::string& image_key, int size, int64_t frames) {
  Clip clip{frames, size, std::vector<float>(static_cast<size_t>(frames) * 3 * size * size)};
  for (int64_t t = 0; t < frames; ++t) {
    tokenize::DecodeFrame(ep.images.at(image_key).frames.at(t), size,
                          clip.pixels.data() + t * 3 * size * size);
  }
  return clip;
}

Clip DecodeClip(const tokenize::Tokenizer& tok, const std::vector<int64_t>& tokens, int64_t first,
                int64_t count, const Clip& given) {
  const int64_t n = tok.tokens_per_frame();
  std::vector<uint32_t> codes(tokens.begin() + first * n, tokens.begin() + (first + count) * n);
  const Clip anchors = RepeatFrame(given, given.frames - 1, count);
  return {count, tok.image_size(), tok.Decode(codes.data(), count, anchors.pixels.data())};
}

}  // namespace wm::evaluate

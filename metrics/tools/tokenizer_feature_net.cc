#include "metrics/tools/tokenizer_feature_net.h"

#include "tokenize/frame_sampler.h"
#include "tokenize/tokenizer.h"

namespace wm::metrics {
namespace {

class TokenizerFeatureNet : public FeatureNet {
 public:
  TokenizerFeatureNet(const std::string& run, const std::string& device) : tok_(run, device) {}
  int image_size() const override { return tok_.image_size(); }
  void Input(const uint8_t* rgb, int height, int width, float* out) const override {
    tokenize::Rgb8ToPlanar(rgb, height, width, tok_.image_size(), out);  // [-1, 1]
  }
  std::vector<double> PerceptualDistance(const float* a, const float* b, int64_t n) const override {
    return tok_.PerceptualDistance(a, b, n);
  }
  std::vector<double> ClipDescriptor(const float* frames, int64_t n) const override {
    return tok_.ClipDescriptor(frames, n);
  }

 private:
  tokenize::Tokenizer tok_;
};

}  // namespace

std::unique_ptr<FeatureNet> OpenTokenizerFeatureNet(const std::string& run,
                                                    const std::string& device) {
  return std::make_unique<TokenizerFeatureNet>(run, device);
}

}  // namespace wm::metrics

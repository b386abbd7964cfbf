#pragma once
// The learned feature network behind lpips_style and fvd_style (docs/metrics.md). metrics/ does
// not build one: the caller wires it in (wm-metrics: a wmkit tokenizer's encoder,
// metrics/tools/tokenizer_feature_net.h), so the metrics libraries stay below the stages whose
// models they can score.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace wm::metrics {

class FeatureNet {
 public:
  virtual ~FeatureNet() = default;
  // S: frames are resized to S x S before they reach the network.
  virtual int image_size() const = 0;
  // One 8-bit RGB frame (interleaved, height x width) as the network's input: planar [3, S, S].
  virtual void Input(const uint8_t* rgb, int height, int width, float* out) const = 0;
  // lpips_style: one distance per frame pair; a and b are n Input frames each.
  virtual std::vector<double> PerceptualDistance(const float* a, const float* b,
                                                 int64_t n) const = 0;
  // fvd_style: the descriptor of one clip of n Input frames.
  virtual std::vector<double> ClipDescriptor(const float* frames, int64_t n) const = 0;
};

// Opens the network that CompareOptions::feature_net names, on `device`.
using FeatureNetLoader = std::function<std::unique_ptr<FeatureNet>(const std::string& feature_net,
                                                                   const std::string& device)>;

}  // namespace wm::metrics

#pragma once
// LPIPS v0.1 with the AlexNet trunk (Zhang et al. 2018, "The Unreasonable Effectiveness of Deep
// Features as a Perceptual Metric"; the `lpips` package, LPIPS(net='alex', version='0.1')), in
// LibTorch, with weights from a wmkit tensor archive (docs/metrics-lpips.md). LibTorch stays in
// lpips.cc: this header is torch-free.
//
//   d(x0, x1) = sum_l mean_hw( w_l . (n(F_l(s(x0))) - n(F_l(s(x1))))^2 )
//
// s: ScalingLayer (x - shift) / scale; F_l: AlexNet relu1..relu5; n: unit norm over channels,
// x / (sqrt(sum_c x^2) + 1e-10); w_l: the non-negative 1x1 "lin" weights of layer l.
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace wm::metrics {

inline constexpr int kLpipsLayers = 5;  // AlexNet relu1..relu5
// AlexNet needs at least 31x31 input for relu5 to have one pixel (two 3/2 max-pools).
inline constexpr int kLpipsMinSide = 31;

struct LpipsOptions {
  // Torch device string: "cpu", "cuda", "cuda:1". Default "cpu".
  std::string device = "cpu";
  // Image pairs per forward pass (each pass runs 2 * batch_size images). Default 16.
  int batch_size = 16;
  // Torch intra-op threads (process-wide setting); 0 leaves torch's default. Default 0.
  int threads = 0;
  // glibc only, process-wide, once: keep freed memory in the heap (mallopt M_MMAP_THRESHOLD
  // 32 MiB, M_TRIM_THRESHOLD 1 GiB). Otherwise glibc hands the buffers of oneDNN's per-pass
  // reorders back to the OS and every pass page-faults them in again: measured 1.5x slower at
  // 64x64 on CPU before the weights were prepacked (docs/metrics-lpips.md, "Speed"). Costs
  // resident memory at the peak. Default on.
  bool tune_malloc = true;
  void Check() const;  // throws wm::Error on a bad value
};

// One unnormalised AlexNet feature map of one image: relu<layer+1>, [C, H, W] row-major.
struct LpipsFeatureMap {
  std::array<int64_t, 3> shape{};  // {C, H, W}
  std::vector<float> data;
};

// One object holds the network on its device; calls on it are not meant to run concurrently
// (each pass already uses torch's intra-op threads).
class Lpips {
 public:
  // Loads and validates the weights (names, shapes, dtypes, CRCs, lin weights >= 0). Throws
  // wm::Error naming the file and the tensor.
  explicit Lpips(const std::string& weights_file, std::string device = "cpu");
  Lpips(const std::string& weights_file, const LpipsOptions& options);
  ~Lpips();
  Lpips(Lpips&&) noexcept;
  Lpips& operator=(Lpips&&) noexcept;

  // LPIPS of each pair (a[i], b[i]): RGB uint8 images, height x width x 3 interleaved, mapped to
  // [-1, 1] as x / 127.5 - 1 (as lpips.im2tensor). height, width >= kLpipsMinSide. 0 for equal
  // images; symmetric; deterministic on CPU for a fixed thread count.
  std::vector<double> Distance(const std::vector<const uint8_t*>& a,
                               const std::vector<const uint8_t*>& b, int height, int width);
  // The same for float RGB images already in [-1, 1], height x width x 3 interleaved.
  std::vector<double> DistanceFloat(const std::vector<const float*>& a,
                                    const std::vector<const float*>& b, int height, int width);
  // Per-layer terms (relu1..relu5) of each pair; Distance() is their sum.
  std::vector<std::array<double, kLpipsLayers>> LayerDistances(const std::vector<const uint8_t*>& a,
                                                               const std::vector<const uint8_t*>& b,
                                                               int height, int width);
  // relu1..relu5 of one uint8 image, before normalisation (for checking the layer taps).
  std::vector<LpipsFeatureMap> Features(const uint8_t* image, int height, int width);

  const std::string& weights_file() const;
  const LpipsOptions& options() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace wm::metrics

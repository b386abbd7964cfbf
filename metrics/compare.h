#pragma once
// What `wm-metrics` does: load reference and prediction frames (files, folders or videos), pair
// them, compute the asked-for metrics per frame and their means, and format JSON or CSV.
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "metrics/feature_net.h"
#include "metrics/lpips/lpips.h"

namespace wm::metrics {

// lpips: one distance per pair of 8-bit RGB frames (height x width x 3), as Lpips::Distance.
using LpipsDistance =
    std::function<std::vector<double>(const std::vector<const uint8_t*>& a,
                                      const std::vector<const uint8_t*>& b, int height, int width)>;
// Opens LPIPS with the weights file. Like the feature network, the caller wires it in, so that
// the comparison itself does not link LibTorch (wm-metrics-full wires in metrics/lpips/).
using LpipsLoader =
    std::function<LpipsDistance(const std::string& weights_file, const LpipsOptions& options)>;

struct CompareOptions {
  std::string ref, pred;  // image file, folder of frames (paired by sorted name) or video
  // also ms_ssim, lpips, lpips_style, fvd_style
  std::vector<std::string> metrics = {"mse", "psnr", "ssim"};
  std::string lpips_weights;  // wmkit tensor archive (scripts/export_lpips_weights.py)
  LpipsLoader lpips_loader;   // opens `lpips_weights` (wm-metrics-full: wm_lpips)
  // lpips_style / fvd_style: a wm-tokenize run directory or checkpoint whose encoder gives the
  // features (docs/metrics.md); frames are resized to its image size.
  std::string feature_net;
  FeatureNetLoader feature_net_loader;  // opens `feature_net` (wm-metrics: a tokenizer's encoder)
  int clip_length = 16;                 // fvd_style: frames per clip (consecutive, non-overlapping)
  // mse / psnr / ssim inside a mask (metrics/masked_metrics.h): an image (every frame) or one
  // mask per frame (folder or video); a pixel is inside when non-zero.
  std::string mask;
  std::string device = "cpu";  // LPIPS device
  int threads = 0;             // 0: all hardware threads
  int chunk_frames = 64;       // frame pairs held in memory at a time (long inputs stream)
  bool per_frame = false;      // add per-frame values
  void Check() const;          // throws wm::Error naming the offending option
};

// Whether the metrics need a learned network (lpips, lpips_style, fvd_style), i.e. LibTorch.
bool NeedsLearnedNetwork(const CompareOptions& options);

// {"mse": .., "psnr": .., ..., "frames": N, ["per_frame": [{"source": .., "psnr": ..}, ...]]};
// +inf PSNR is "inf" (JSON has no infinity). fvd_style is one value for the whole set (per-frame
// rows carry null), with "fvd_style_clips": the clips per side.
nlohmann::json CompareFrameSets(const CompareOptions& options);

// One CSV: a header and a row of means, or with per-frame values one row per frame + "mean".
std::string FormatCsv(const nlohmann::json& result, const std::vector<std::string>& metrics);

}  // namespace wm::metrics

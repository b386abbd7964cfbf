#include "metrics/compare.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "core/error.h"
#include "metrics/frechet.h"
#include "metrics/image_io.h"
#include "metrics/lpips/lpips.h"
#include "metrics/masked_metrics.h"
#include "metrics/pixel_metrics.h"
#include "tokenize/frame_sampler.h"
#include "tokenize/tokenizer.h"

namespace wm::metrics {
namespace {
using nlohmann::json;

const std::vector<std::string> kKnown = {"mse",   "psnr",        "ssim",     "ms_ssim",
                                         "lpips", "lpips_style", "fvd_style"};

bool Wants(const CompareOptions& o, const std::string& m) {
  return std::find(o.metrics.begin(), o.metrics.end(), m) != o.metrics.end();
}

// LPIPS reads 8-bit RGB; the loaders give doubles in [0, data_range].
std::vector<uint8_t> ToRgb8(const Image& image) {
  Check(image.channels == 3 && image.data_range == 255.0,
        "lpips needs 8-bit RGB frames, got " + ShapeString(image) + " with data range " +
            std::to_string(image.data_range));
  std::vector<uint8_t> out(image.size());
  for (size_t i = 0; i < out.size(); ++i)
    out[i] = static_cast<uint8_t>(std::lround(image.pixels[i]));
  return out;
}

std::vector<double> LpipsOf(const CompareOptions& o, const Frames& ref, const Frames& pred) {
  LpipsOptions lo;
  lo.device = o.device;
  lo.threads = o.threads;
  Lpips net(o.lpips_weights, lo);
  std::vector<std::vector<uint8_t>> a, b;
  std::vector<const uint8_t*> pa, pb;
  for (size_t i = 0; i < ref.images.size(); ++i) {
    a.push_back(ToRgb8(ref.images[i]));
    b.push_back(ToRgb8(pred.images[i]));
  }
  for (size_t i = 0; i < a.size(); ++i) pa.push_back(a[i].data()), pb.push_back(b[i].data());
  return net.Distance(pa, pb, ref.images[0].height, ref.images[0].width);
}

// Every frame as the tokenizer sees it: planar [n, 3, S, S] in [-1, 1].
std::vector<float> TokenizerInput(const Frames& frames, int size) {
  const size_t floats = 3ull * size * size;
  std::vector<float> out(frames.images.size() * floats);
  for (size_t i = 0; i < frames.images.size(); ++i) {
    const Image& image = frames.images[i];
    const std::vector<uint8_t> rgb = ToRgb8(image);
    tokenize::Rgb8ToPlanar(rgb.data(), image.height, image.width, size, out.data() + i * floats);
  }
  return out;
}

// fvd_style between the clip sets of the two sides (clip_length consecutive frames per clip).
double FvdStyle(const tokenize::Tokenizer& tok, const std::vector<float>& ref,
                const std::vector<float>& pred, int64_t frames, int clip_length, int64_t* clips) {
  const size_t floats = 3ull * tok.image_size() * tok.image_size();
  *clips = frames / clip_length;
  FeatureSet a, b;
  for (int64_t c = 0; c < *clips; ++c) {
    for (auto [set, pixels] : {std::pair{&a, &ref}, std::pair{&b, &pred}}) {
      const std::vector<double> d =
          tok.ClipDescriptor(pixels->data() + c * clip_length * floats, clip_length);
      set->dim = static_cast<int64_t>(d.size());
      set->rows += 1;
      set->values.insert(set->values.end(), d.begin(), d.end());
    }
  }
  return FrechetDistance(a, b);
}

// Per frame, mse / psnr / ssim inside the mask, as FrameMetrics (ms_ssim unused).
std::vector<FrameMetrics> MaskedFrames(const CompareOptions& o, const Frames& ref,
                                       const Frames& pred, std::vector<int64_t>* pixels) {
  const Frames masks = LoadFrames(o.mask);
  Check(masks.images.size() == 1 || masks.images.size() == ref.images.size(),
        "expected one mask for every frame or one per frame (" + std::to_string(ref.images.size()) +
            "), found " + std::to_string(masks.images.size()),
        {.file = o.mask});
  std::vector<FrameMetrics> out;
  for (size_t i = 0; i < ref.images.size(); ++i) {
    const size_t m = masks.images.size() == 1 ? 0 : i;
    MaskedMetrics r;
    try {
      r = CompareMasked(ref.images[i], pred.images[i], masks.images[m], Wants(o, "ssim"),
                        o.threads);
    } catch (const Error& e) {
      throw Error(e.message(), {.file = masks.sources[m]});
    }
    out.push_back({.mse = r.mse, .psnr = r.psnr, .ssim = r.ssim, .ms_ssim = NAN});
    pixels->push_back(r.pixels);
  }
  return out;
}

double Mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? NAN : s / static_cast<double>(v.size());
}

}  // namespace

void CompareOptions::Check() const {
  wm::Check(!ref.empty() && !pred.empty(), "--ref and --pred are required");
  wm::Check(!metrics.empty(), "--metrics names no metric");
  for (const auto& m : metrics) {
    wm::Check(std::find(kKnown.begin(), kKnown.end(), m) != kKnown.end(),
              "unknown metric '" + m +
                  "' (known: mse, psnr, ssim, ms_ssim, lpips, lpips_style, fvd_style)",
              {.key = "--metrics"});
    wm::Check(!(m == "lpips_style" || m == "fvd_style") || !feature_net.empty(),
              m + " needs --feature-net: a wm-tokenize run whose encoder gives the features");
  }
  wm::Check(clip_length >= 1, "must be >= 1", {.key = "--clip-length"});
  for (const auto& m : metrics) {
    wm::Check(mask.empty() || m == "mse" || m == "psnr" || m == "ssim",
              "--mask restricts mse, psnr and ssim only; '" + m + "' has no masked form",
              {.key = "--metrics"});
  }
  wm::Check(!Wants(*this, "lpips") || !lpips_weights.empty(),
            "lpips needs --lpips-weights FILE (made once by scripts/export_lpips_weights.py)");
}

json CompareFrameSets(const CompareOptions& o) {
  o.Check();
  Frames ref = LoadFrames(o.ref), pred = LoadFrames(o.pred);
  CheckPaired(ref, pred);
  MetricOptions mo;
  mo.ssim = Wants(o, "ssim");
  mo.ms_ssim = Wants(o, "ms_ssim");
  mo.threads = o.threads;
  VideoMetrics video;
  std::vector<int64_t> mask_pixels;
  if (o.mask.empty()) {
    video = CompareVideos(ref.images, pred.images, mo);
  } else {  // frames whose mask is empty are left out of the means
    video.frames = MaskedFrames(o, ref, pred, &mask_pixels);
    std::vector<FrameMetrics> defined;
    for (const auto& f : video.frames) {
      if (!std::isnan(f.mse)) defined.push_back(f);
    }
    Check(!defined.empty(), "the mask is empty in every frame", {.file = o.mask});
    video.mean = MeanMetrics(defined);
  }
  std::map<std::string, std::vector<double>> deep;  // per-frame values of the deep metrics
  if (Wants(o, "lpips")) deep["lpips"] = LpipsOf(o, ref, pred);
  json result = json::object();
  if (Wants(o, "lpips_style") || Wants(o, "fvd_style")) {
    const tokenize::Tokenizer tok(o.feature_net, o.device);
    const std::vector<float> a = TokenizerInput(ref, tok.image_size());
    const std::vector<float> b = TokenizerInput(pred, tok.image_size());
    const auto n = static_cast<int64_t>(ref.images.size());
    if (Wants(o, "lpips_style"))
      deep["lpips_style"] = tok.PerceptualDistance(a.data(), b.data(), n);
    if (Wants(o, "fvd_style")) {
      int64_t clips = 0;
      Check(n >= 2 * o.clip_length,
            "fvd_style needs at least 2 clips of --clip-length (" + std::to_string(o.clip_length) +
                ") frames, got " + std::to_string(n) + " frames",
            {.file = o.ref});
      result["fvd_style"] = FvdStyle(tok, a, b, n, o.clip_length, &clips);
      result["fvd_style_clips"] = clips;
    }
  }

  json means = ToJson(video.mean);
  for (const auto& m : o.metrics) {
    if (m == "fvd_style") continue;
    result[m] = deep.count(m) ? json(Mean(deep[m])) : means.value(m, json(nullptr));
  }
  result["frames"] = ref.images.size();
  if (!o.mask.empty()) result["mask"] = o.mask;
  if (o.per_frame) {
    json rows = json::array();
    for (size_t i = 0; i < ref.images.size(); ++i) {
      json all = ToJson(video.frames[i]), row = {{"source", pred.sources[i]}};
      if (!mask_pixels.empty()) row["mask_pixels"] = mask_pixels[i];
      for (const auto& m : o.metrics) {
        row[m] = m == "fvd_style" ? json(nullptr)
                 : deep.count(m)  ? json(deep[m][i])
                                  : all.value(m, json(nullptr));
      }
      rows.push_back(row);
    }
    result["per_frame"] = rows;
  }
  return result;
}

std::string FormatCsv(const json& result, const std::vector<std::string>& metrics) {
  auto cell = [](const json& v) {
    return v.is_null() ? std::string() : v.is_string() ? v.get<std::string>() : v.dump();
  };
  std::string out = "frame";
  for (const auto& m : metrics) out += "," + m;
  out += "\n";
  for (const auto& row : result.value("per_frame", json::array())) {
    out += cell(row.at("source"));
    for (const auto& m : metrics) out += "," + cell(row.at(m));
    out += "\n";
  }
  out += "mean";
  for (const auto& m : metrics) out += "," + cell(result.at(m));
  return out + "\n";
}

}  // namespace wm::metrics

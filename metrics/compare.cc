#include "metrics/compare.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <future>
#include <map>
#include <optional>

#include "core/error.h"
#include "metrics/frechet.h"
#include "metrics/image_io.h"
#include "metrics/masked_metrics.h"
#include "metrics/pixel_metrics.h"

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

// Every frame as the feature net sees it: planar [n, 3, S, S].
std::vector<float> FeatureNetInput(const FeatureNet& net, const Frames& frames) {
  const size_t floats = 3ull * net.image_size() * net.image_size();
  std::vector<float> out(frames.images.size() * floats);
  for (size_t i = 0; i < frames.images.size(); ++i) {
    const Image& image = frames.images[i];
    const std::vector<uint8_t> rgb = ToRgb8(image);
    net.Input(rgb.data(), image.height, image.width, out.data() + i * floats);
  }
  return out;
}

// The next chunk of both inputs. Unless --threads is 1, the reference is decoded on a second
// thread meanwhile: decoding (PNG inflate) takes about half of a folder comparison's CPU time.
// The reference's error still comes first, as when the two are read in turn.
std::pair<size_t, size_t> ReadBoth(FrameStream& ref, FrameStream& pred, size_t max_frames,
                                   int threads, Frames* a, Frames* b) {
  if (threads == 1) {
    const size_t na = ref.Read(max_frames, a);
    return {na, pred.Read(max_frames, b)};
  }
  std::future<size_t> ref_read =
      std::async(std::launch::async, [&] { return ref.Read(max_frames, a); });
  std::exception_ptr pred_error;
  size_t nb = 0;
  try {
    nb = pred.Read(max_frames, b);
  } catch (...) {
    pred_error = std::current_exception();
  }
  const size_t na = ref_read.get();
  if (pred_error) std::rethrow_exception(pred_error);
  return {na, nb};
}

double Mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? NAN : s / static_cast<double>(v.size());
}

// One comparison, fed a chunk of frame pairs at a time; keeps only per-frame numbers (and, for
// fvd_style, the frames of one unfinished clip).
class Comparison {
 public:
  explicit Comparison(const CompareOptions& o) : o_(o) {
    mo_.ssim = Wants(o, "ssim");
    mo_.ms_ssim = Wants(o, "ms_ssim");
    mo_.threads = o.threads;
    if (Wants(o, "lpips")) {
      Check(static_cast<bool>(o.lpips_loader),
            "lpips needs LibTorch, and this program wires in none");
      lpips_ = o.lpips_loader(o.lpips_weights, {.device = o.device, .threads = o.threads});
    }
    if (Wants(o, "lpips_style") || Wants(o, "fvd_style")) {
      Check(static_cast<bool>(o.feature_net_loader),
            "lpips_style and fvd_style need a feature network, and this program wires in none");
      features_ = o.feature_net_loader(o.feature_net, o.device);
    }
    if (!o.mask.empty()) {  // a source of exactly one mask applies it to every frame
      masks_.emplace(o.mask);
      masks_->Read(2, &pending_masks_);
      if (pending_masks_.images.size() == 1) {
        one_mask_ = std::move(pending_masks_);
        pending_masks_ = {};
        masks_.reset();
      }
    }
  }

  void Add(const Frames& ref, const Frames& pred) {
    for (const auto& src : pred.sources) sources_.push_back(src);
    if (o_.mask.empty()) {
      const auto f = CompareFrames(ref.images, pred.images, mo_);
      frames_.insert(frames_.end(), f.begin(), f.end());
    } else {
      AddMasked(ref, pred);
    }
    if (lpips_) {
      std::vector<std::vector<uint8_t>> a, b;
      std::vector<const uint8_t*> pa, pb;
      for (size_t i = 0; i < ref.images.size(); ++i) {
        a.push_back(ToRgb8(ref.images[i]));
        b.push_back(ToRgb8(pred.images[i]));
      }
      for (size_t i = 0; i < a.size(); ++i) pa.push_back(a[i].data()), pb.push_back(b[i].data());
      Append("lpips", lpips_(pa, pb, ref.images[0].height, ref.images[0].width));
    }
    if (features_) {
      const std::vector<float> a = FeatureNetInput(*features_, ref);
      const std::vector<float> b = FeatureNetInput(*features_, pred);
      const auto n = static_cast<int64_t>(ref.images.size());
      if (Wants(o_, "lpips_style")) {
        Append("lpips_style", features_->PerceptualDistance(a.data(), b.data(), n));
      }
      if (Wants(o_, "fvd_style")) AddClipFrames(a, b);
    }
  }

  json Result() {
    if (masks_) {
      Frames extra = std::move(pending_masks_);
      Check(extra.images.empty() && masks_->Read(1, &extra) == 0,
            "more masks than frames (" + std::to_string(frames_.size()) + ")", {.file = o_.mask});
    }
    json result = json::object();
    if (Wants(o_, "fvd_style")) {
      Check(fvd_ref_.rows >= 2,
            "fvd_style needs at least 2 clips of --clip-length (" + std::to_string(o_.clip_length) +
                ") frames, got " + std::to_string(frames_.size()) + " frames",
            {.file = o_.ref});
      result["fvd_style"] = FrechetDistance(fvd_ref_, fvd_pred_);
      result["fvd_style_clips"] = fvd_ref_.rows;
    }
    std::vector<FrameMetrics> defined;  // frames whose mask is empty are left out of the means
    for (const auto& f : frames_) {
      if (!std::isnan(f.mse)) defined.push_back(f);
    }
    Check(!defined.empty(), "the mask is empty in every frame", {.file = o_.mask});
    const json means = ToJson(MeanMetrics(defined));
    for (const auto& m : o_.metrics) {
      if (m == "fvd_style") continue;
      result[m] = deep_.count(m) ? json(Mean(deep_[m])) : means.value(m, json(nullptr));
    }
    result["frames"] = frames_.size();
    if (!o_.mask.empty()) result["mask"] = o_.mask;
    if (o_.per_frame) {
      json rows = json::array();
      for (size_t i = 0; i < frames_.size(); ++i) {
        json all = ToJson(frames_[i]), row = {{"source", sources_[i]}};
        if (!mask_pixels_.empty()) row["mask_pixels"] = mask_pixels_[i];
        for (const auto& m : o_.metrics) {
          row[m] = m == "fvd_style" ? json(nullptr)
                   : deep_.count(m) ? json(deep_[m][i])
                                    : all.value(m, json(nullptr));
        }
        rows.push_back(row);
      }
      result["per_frame"] = rows;
    }
    return result;
  }

 private:
  void Append(const std::string& metric, const std::vector<double>& values) {
    auto& v = deep_[metric];
    v.insert(v.end(), values.begin(), values.end());
  }

  // mse / psnr / ssim inside the mask of each frame (ms_ssim unused).
  void AddMasked(const Frames& ref, const Frames& pred) {
    Frames chunk = std::move(pending_masks_);
    pending_masks_ = {};
    if (masks_) {
      const size_t want = ref.images.size();
      if (chunk.images.size() < want) masks_->Read(want - chunk.images.size(), &chunk);
      Check(chunk.images.size() >= want,
            "fewer masks than frames: expected one mask for every frame or one per frame, found " +
                std::to_string(frames_.size() + chunk.images.size()) + " masks for more frames",
            {.file = o_.mask});
      pending_masks_.images.assign(chunk.images.begin() + want, chunk.images.end());
      pending_masks_.sources.assign(chunk.sources.begin() + want, chunk.sources.end());
      chunk.images.resize(want);
      chunk.sources.resize(want);
    }
    const Frames& masks = masks_ ? chunk : one_mask_;
    for (size_t i = 0; i < ref.images.size(); ++i) {
      const size_t m = masks_ ? i : 0;
      MaskedMetrics r;
      try {
        r = CompareMasked(ref.images[i], pred.images[i], masks.images[m], Wants(o_, "ssim"),
                          o_.threads);
      } catch (const Error& e) {
        throw Error(e.message(), {.file = masks.sources[m]});
      }
      frames_.push_back({.mse = r.mse, .psnr = r.psnr, .ssim = r.ssim, .ms_ssim = NAN});
      mask_pixels_.push_back(r.pixels);
    }
  }

  // fvd_style: consecutive clips of clip_length frames; a clip may span chunks.
  void AddClipFrames(const std::vector<float>& a, const std::vector<float>& b) {
    const size_t floats = 3ull * features_->image_size() * features_->image_size();
    const size_t clip = static_cast<size_t>(o_.clip_length) * floats;
    carry_ref_.insert(carry_ref_.end(), a.begin(), a.end());
    carry_pred_.insert(carry_pred_.end(), b.begin(), b.end());
    size_t used = 0;
    for (; carry_ref_.size() - used >= clip; used += clip) {
      for (auto [set, pixels] :
           {std::pair{&fvd_ref_, &carry_ref_}, std::pair{&fvd_pred_, &carry_pred_}}) {
        const std::vector<double> d =
            features_->ClipDescriptor(pixels->data() + used, o_.clip_length);
        set->dim = static_cast<int64_t>(d.size());
        set->rows += 1;
        set->values.insert(set->values.end(), d.begin(), d.end());
      }
    }
    carry_ref_.erase(carry_ref_.begin(), carry_ref_.begin() + used);
    carry_pred_.erase(carry_pred_.begin(), carry_pred_.begin() + used);
  }

  const CompareOptions& o_;
  MetricOptions mo_;
  LpipsDistance lpips_;
  std::unique_ptr<FeatureNet> features_;  // lpips_style / fvd_style
  std::optional<FrameStream> masks_;
  Frames one_mask_;
  Frames pending_masks_;  // read ahead of the frames they belong to
  std::vector<FrameMetrics> frames_;
  std::vector<std::string> sources_;
  std::vector<int64_t> mask_pixels_;
  std::map<std::string, std::vector<double>> deep_;  // per-frame values of the deep metrics
  FeatureSet fvd_ref_, fvd_pred_;
  std::vector<float> carry_ref_, carry_pred_;
};

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
  wm::Check(chunk_frames >= 1, "must be >= 1", {.key = "--chunk-frames"});
  for (const auto& m : metrics) {
    wm::Check(mask.empty() || m == "mse" || m == "psnr" || m == "ssim",
              "--mask restricts mse, psnr and ssim only; '" + m + "' has no masked form",
              {.key = "--metrics"});
  }
  wm::Check(!Wants(*this, "lpips") || !lpips_weights.empty(),
            "lpips needs --lpips-weights FILE (made once by scripts/export_lpips_weights.py)");
}

bool NeedsLearnedNetwork(const CompareOptions& o) {
  return Wants(o, "lpips") || Wants(o, "lpips_style") || Wants(o, "fvd_style");
}

json CompareFrameSets(const CompareOptions& o) {
  o.Check();
  FrameStream ref(o.ref), pred(o.pred);
  Comparison comparison(o);
  size_t total = 0;
  for (;;) {
    Frames a, b;
    const auto [na, nb] = ReadBoth(ref, pred, o.chunk_frames, o.threads, &a, &b);
    Check(na == nb, "frame counts differ: " + o.ref + " has " +
                        (na < nb ? std::to_string(total + na) : "more") + " frames, " + o.pred +
                        " has " + (nb < na ? std::to_string(total + nb) : "more"));
    if (na == 0) break;
    CheckPaired(a, b);
    comparison.Add(a, b);
    total += na;
  }
  return comparison.Result();
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

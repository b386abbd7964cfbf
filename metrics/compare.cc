#include "metrics/compare.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "metrics/image_io.h"
#include "metrics/lpips/lpips.h"
#include "metrics/pixel_metrics.h"

namespace wm::metrics {
namespace {
using nlohmann::json;

const std::vector<std::string> kKnown = {"mse", "psnr", "ssim", "ms_ssim", "lpips"};

bool Wants(const CompareOptions& o, const std::string& m) {
  return std::find(o.metrics.begin(), o.metrics.end(), m) != o.metrics.end();
}

// LPIPS reads 8-bit RGB; the loaders give doubles in [0, data_range].
std::vector<uint8_t> ToRgb8(const Image& image) {
  Check(image.channels == 3 && image.data_range == 255.0,
        "lpips needs 8-bit RGB frames, got " + ShapeString(image) + " with data range " +
            std::to_string(image.data_range));
  std::vector<uint8_t> out(image.size());
  for (size_t i = 0; i < out.size(); ++i) out[i] = static_cast<uint8_t>(std::lround(image.pixels[i]));
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
    if (m == "lpips_style" || m == "fvd_style") {
      throw Error("metric '" + m + "' needs a wmkit tokenizer checkpoint's encoder features, "
                  "which wm-tokenize does not produce yet (see README, Status)");
    }
    wm::Check(std::find(kKnown.begin(), kKnown.end(), m) != kKnown.end(),
              "unknown metric '" + m + "' (known: mse, psnr, ssim, ms_ssim, lpips)",
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
  VideoMetrics video = CompareVideos(ref.images, pred.images, mo);
  std::vector<double> lpips;
  if (Wants(o, "lpips")) lpips = LpipsOf(o, ref, pred);

  json means = ToJson(video.mean), result = json::object();
  for (const auto& m : o.metrics) result[m] = m == "lpips" ? json(Mean(lpips)) : means.at(m);
  result["frames"] = ref.images.size();
  if (o.per_frame) {
    json rows = json::array();
    for (size_t i = 0; i < ref.images.size(); ++i) {
      json all = ToJson(video.frames[i]), row = {{"source", pred.sources[i]}};
      for (const auto& m : o.metrics) row[m] = m == "lpips" ? json(lpips[i]) : all.at(m);
      rows.push_back(row);
    }
    result["per_frame"] = rows;
  }
  return result;
}

std::string FormatCsv(const json& result, const std::vector<std::string>& metrics) {
  auto cell = [](const json& v) { return v.is_string() ? v.get<std::string>() : v.dump(); };
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

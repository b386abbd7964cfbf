#include "tokenize/frame_sampler.h"

#include <algorithm>
#include <cmath>

#ifdef WM_HAVE_OPENCV
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#endif

#include "core/error.h"
#include "core/mix_bits.h"
#include "core/image_codec.h"
#include "core/shard/dataset_reader.h"

namespace wm::tokenize {
namespace {

// [height, width, 3] RGB at exactly size x size -> planar floats in [-1, 1].
void SquareRgb8ToPlanar(const uint8_t* rgb, int size, float* out) {
  const size_t plane = static_cast<size_t>(size) * size;
  for (size_t p = 0; p < plane; ++p) {
    for (int c = 0; c < 3; ++c) out[c * plane + p] = rgb[3 * p + c] / 127.5f - 1.f;
  }
}

}  // namespace

#ifdef WM_HAVE_OPENCV
void DecodeFrame(const std::string& encoded, int size, float* out) {
  cv::Mat buf(1, static_cast<int>(encoded.size()), CV_8UC1, const_cast<char*>(encoded.data()));
  cv::Mat bgr = cv::imdecode(buf, cv::IMREAD_COLOR);
  Check(!bgr.empty(), "cannot decode frame (" + std::to_string(encoded.size()) + " bytes)");
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  Rgb8ToPlanar(rgb.ptr<uint8_t>(), rgb.rows, rgb.cols, size, out);
}

void Rgb8ToPlanar(const uint8_t* rgb, int height, int width, int size, float* out) {
  const cv::Mat in(height, width, CV_8UC3, const_cast<uint8_t*>(rgb));  // only read
  cv::Mat resized = in;
  if (height != size || width != size) {
    cv::resize(in, resized, cv::Size(size, size), 0, 0, cv::INTER_AREA);
  }
  SquareRgb8ToPlanar(resized.isContinuous() ? resized.ptr<uint8_t>() : resized.clone().data, size,
                     out);
}
#else
// Without OpenCV (WM_MODEL_ONLY, docs/gpu.md): libpng/libjpeg decode and the resampling below.
void DecodeFrame(const std::string& encoded, int size, float* out) {
  const DecodedImage image = DecodePngOrJpeg(encoded, "frame");
  Check(image.bit_depth == 8, "cannot decode frame: 16-bit images are not camera frames");
  std::vector<uint8_t> rgb;
  const uint8_t* pixels = image.data.data();
  if (image.channels == 1) {  // grey frames feed the colour model as equal channels
    rgb.resize(image.data.size() * 3);
    for (size_t i = 0; i < image.data.size(); ++i)
      rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = image.data[i];
    pixels = rgb.data();
  }
  Rgb8ToPlanar(pixels, image.height, image.width, size, out);
}

// Area resampling (each output pixel the mean of the input area it covers, as OpenCV's
// INTER_AREA when shrinking), rounded to uint8 like OpenCV's.
void Rgb8ToPlanar(const uint8_t* rgb, int height, int width, int size, float* out) {
  if (height == size && width == size) return SquareRgb8ToPlanar(rgb, size, out);
  std::vector<uint8_t> resized(static_cast<size_t>(size) * size * 3);
  const double sy = double(height) / size, sx = double(width) / size;
  for (int y = 0; y < size; ++y) {
    const double y0 = y * sy, y1 = (y + 1) * sy;
    for (int x = 0; x < size; ++x) {
      const double x0 = x * sx, x1 = (x + 1) * sx;
      double sum[3] = {0, 0, 0}, area = 0;
      for (int iy = int(y0); iy < std::min(height, int(std::ceil(y1))); ++iy) {
        const double wy = std::min(y1, iy + 1.0) - std::max(y0, double(iy));
        for (int ix = int(x0); ix < std::min(width, int(std::ceil(x1))); ++ix) {
          const double w = wy * (std::min(x1, ix + 1.0) - std::max(x0, double(ix)));
          for (int c = 0; c < 3; ++c) sum[c] += w * rgb[(size_t(iy) * width + ix) * 3 + c];
          area += w;
        }
      }
      for (int c = 0; c < 3; ++c)
        resized[(size_t(y) * size + x) * 3 + c] = uint8_t(std::lround(sum[c] / area));
    }
  }
  SquareRgb8ToPlanar(resized.data(), size, out);
}
#endif

FrameSampler::FrameSampler(const std::vector<std::string>& dataset_dirs, std::string image_key,
                           int size, uint64_t seed, std::vector<double> weights)
    : image_key_(std::move(image_key)), size_(size), seed_(seed) {
  Check(!dataset_dirs.empty(), "no datasets given (--data)");
  for (const std::string& dir : dataset_dirs) {
    readers_.push_back(std::make_unique<shard::DatasetReader>(dir));
    Check(readers_.back()->index().num_steps > 0, "dataset has no frames", {.file = dir});
  }
  if (weights.empty()) weights = step_counts();
  Check(weights.size() == readers_.size(), "one mixture weight per dataset is needed");
  double total = 0;
  for (double w : weights) total += w;
  double acc = 0;
  for (double w : weights) weights_prefix_.push_back((acc += w) / total);
  weights_prefix_.back() = 1.0;
}

FrameSampler::~FrameSampler() = default;

namespace {

// The hash key of (batch step, slot): every draw of the slot is MixBits(key + i), i distinct.
uint64_t SlotKey(uint64_t seed, int64_t step, int slot) {
  return MixBits(seed ^ MixBits(static_cast<uint64_t>(step) * 0x10000ull + slot));
}

}  // namespace

std::vector<AnchorRef> FixedGapAnchors(const std::vector<FrameRef>& frames, int gap) {
  std::vector<AnchorRef> anchors;
  for (FrameRef f : frames) {
    const bool blank = f.step == 0;
    f.step -= std::min<size_t>(f.step, static_cast<size_t>(gap));
    anchors.push_back({f, blank});
  }
  return anchors;
}

std::vector<AnchorRef> FrameSampler::TrainingAnchors(const std::vector<FrameRef>& frames,
                                                     int64_t step, int max_gap,
                                                     double dropout) const {
  std::vector<AnchorRef> anchors;
  for (size_t b = 0; b < frames.size(); ++b) {
    const uint64_t key = SlotKey(seed_, step, static_cast<int>(b));
    const double u = static_cast<double>(MixBits(key + 4) >> 11) * 0x1.0p-53;  // [0, 1)
    FrameRef f = frames[b];
    const size_t span = std::min<size_t>(f.step, static_cast<size_t>(max_gap));
    const bool blank = span == 0 || u < dropout;
    if (!blank) f.step -= 1 + MixBits(key + 5) % span;
    anchors.push_back({f, blank});
  }
  return anchors;
}

void FrameSampler::Load(const std::vector<AnchorRef>& anchors, float* out) const {
  std::vector<FrameRef> refs;
  for (const AnchorRef& a : anchors) refs.push_back(a.frame);
  Load(refs, out);
  const size_t floats = 3ull * size_ * size_;
  for (size_t b = 0; b < anchors.size(); ++b) {
    if (anchors[b].blank) std::fill(out + b * floats, out + (b + 1) * floats, 0.f);
  }
}

std::vector<FrameRef> FrameSampler::BatchRefs(int64_t step, int batch_size) const {
  std::vector<FrameRef> refs(static_cast<size_t>(batch_size));
  for (int b = 0; b < batch_size; ++b) {
    const uint64_t key = SlotKey(seed_, step, b);
    const double u = static_cast<double>(MixBits(key + 1) >> 11) * 0x1.0p-53;  // [0, 1)
    FrameRef& r = refs[b];
    while (r.dataset + 1 < weights_prefix_.size() && u >= weights_prefix_[r.dataset]) ++r.dataset;
    const shard::DatasetReader& reader = *readers_[r.dataset];
    // `x % n` has a bias below n / 2^64: negligible, and identical on every platform.
    r.episode = MixBits(key + 2) % reader.num_episodes();
    const auto [shard, local] = reader.Locate(r.episode);
    r.step = MixBits(key + 3) % reader.shard(shard).entries()[local].num_steps;
  }
  return refs;
}

std::vector<std::vector<FrameRef>> FrameSampler::EpisodeRefs(size_t max_episodes) const {
  std::vector<std::vector<FrameRef>> out;
  for (size_t d = 0; d < readers_.size(); ++d) {
    const shard::DatasetReader& reader = *readers_[d];
    for (size_t e = 0; e < reader.num_episodes() && out.size() < max_episodes; ++e) {
      const auto [shard, local] = reader.Locate(e);
      std::vector<FrameRef>& clip = out.emplace_back();
      for (size_t t = 0; t < reader.shard(shard).entries()[local].num_steps; ++t)
        clip.push_back({d, e, t});
    }
  }
  return out;
}

void FrameSampler::Load(const std::vector<FrameRef>& refs, float* out) const {
  const size_t frame_floats = 3ull * size_ * size_;
  std::vector<bool> done(refs.size(), false);
  for (size_t i = 0; i < refs.size(); ++i) {
    if (done[i]) continue;
    const shard::DatasetReader& reader = *readers_[refs[i].dataset];
    const size_t k = refs[i].episode;
    Episode episode = reader.ReadEpisode(k);
    auto it = episode.images.find(image_key_);
    Check(it != episode.images.end() && !it->second.frames.empty(),
          "episode has no image stream '" + image_key_ + "'",
          {.file = reader.dir(), .record = static_cast<int64_t>(k), .record_label = "episode"});
    for (size_t j = i; j < refs.size(); ++j) {  // every slot drawn from this episode
      if (done[j] || refs[j].dataset != refs[i].dataset || refs[j].episode != k) continue;
      try {
        DecodeFrame(it->second.frames.at(refs[j].step), size_, out + frame_floats * j);
      } catch (const Error& e) {
        throw e.WithFile(reader.dir()).WithRecord(static_cast<int64_t>(k), "episode");
      }
      done[j] = true;
    }
  }
}

std::vector<std::string> FrameSampler::dataset_names() const {
  std::vector<std::string> names;
  for (const auto& r : readers_) names.push_back(r->index().dataset);
  return names;
}

std::vector<double> FrameSampler::step_counts() const {
  std::vector<double> counts;
  for (const auto& r : readers_) counts.push_back(static_cast<double>(r->index().num_steps));
  return counts;
}

nlohmann::json FrameSampler::DataProvenance() const {
  nlohmann::json out = nlohmann::json::array();
  for (size_t d = 0; d < readers_.size(); ++d) {
    const auto& index = readers_[d]->index();
    nlohmann::json shards = nlohmann::json::array();
    for (const auto& s : index.shards) shards.push_back({{"file", s.file}, {"sha256", s.sha256}});
    out.push_back({{"dataset", index.dataset},
                   {"split", index.split},
                   {"weight", weights_prefix_[d] - (d ? weights_prefix_[d - 1] : 0.0)},
                   {"index_config_hash", index.provenance.value("config_hash", "")},
                   {"num_steps", index.num_steps},
                   {"shards", shards}});
  }
  return out;
}

}  // namespace wm::tokenize

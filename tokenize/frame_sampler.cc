#include "tokenize/frame_sampler.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "core/error.h"
#include "core/shard/dataset_reader.h"

namespace wm::tokenize {

void DecodeFrame(const std::string& encoded, int size, float* out) {
  cv::Mat buf(1, static_cast<int>(encoded.size()), CV_8UC1, const_cast<char*>(encoded.data()));
  cv::Mat bgr = cv::imdecode(buf, cv::IMREAD_COLOR);
  Check(!bgr.empty(), "cannot decode frame (" + std::to_string(encoded.size()) + " bytes)");
  cv::Mat rgb, resized;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  if (rgb.rows != size || rgb.cols != size) {
    cv::resize(rgb, resized, cv::Size(size, size), 0, 0, cv::INTER_AREA);
  } else {
    resized = rgb;
  }
  const size_t plane = static_cast<size_t>(size) * size;
  for (int y = 0; y < size; ++y) {
    const uint8_t* row = resized.ptr<uint8_t>(y);
    for (int x = 0; x < size; ++x) {
      for (int c = 0; c < 3; ++c) {
        out[c * plane + static_cast<size_t>(y) * size + x] = row[3 * x + c] / 127.5f - 1.f;
      }
    }
  }
}

FrameSampler::FrameSampler(const std::vector<std::string>& dataset_dirs, std::string image_key,
                           int size, uint64_t seed)
    : image_key_(std::move(image_key)), size_(size), rng_(seed) {
  Check(!dataset_dirs.empty(), "no datasets given (--data)");
  uint64_t total = 0;
  for (const std::string& dir : dataset_dirs) {
    readers_.push_back(std::make_unique<shard::DatasetReader>(dir));
    const auto& index = readers_.back()->index();
    Check(index.num_steps > 0, "dataset has no frames", {.file = dir});
    total += index.num_steps;
    steps_prefix_.push_back(total);
  }
}

FrameSampler::~FrameSampler() = default;

void FrameSampler::NextBatch(int batch_size, std::vector<float>& batch) {
  const size_t frame_floats = 3ull * size_ * size_;
  batch.resize(frame_floats * batch_size);
  for (int b = 0; b < batch_size; ++b) {
    const uint64_t r = rng_() % steps_prefix_.back();
    size_t d = 0;
    while (r >= steps_prefix_[d]) ++d;
    const shard::DatasetReader& reader = *readers_[d];
    const size_t k = rng_() % reader.num_episodes();
    Episode episode = reader.ReadEpisode(k);
    auto it = episode.images.find(image_key_);
    Check(it != episode.images.end() && !it->second.frames.empty(),
          "episode has no image stream '" + image_key_ + "'",
          {.file = reader.dir(), .record = static_cast<int64_t>(k), .record_label = "episode"});
    const auto& frames = it->second.frames;
    const size_t t = rng_() % frames.size();
    try {
      DecodeFrame(frames[t], size_, batch.data() + frame_floats * b);
    } catch (const Error& e) {
      throw e.WithFile(reader.dir()).WithRecord(static_cast<int64_t>(k), "episode");
    }
  }
}

std::string FrameSampler::rng_state() const {
  std::ostringstream s;
  s << rng_;
  return s.str();
}

void FrameSampler::set_rng_state(const std::string& state) {
  std::istringstream s(state);
  s >> rng_;
  Check(!s.fail(), "corrupt sampler RNG state");
}

nlohmann::json FrameSampler::DataProvenance() const {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& reader : readers_) {
    const auto& index = reader->index();
    nlohmann::json shards = nlohmann::json::array();
    for (const auto& s : index.shards) shards.push_back({{"file", s.file}, {"sha256", s.sha256}});
    out.push_back({{"dataset", index.dataset},
                   {"split", index.split},
                   {"index_config_hash", index.provenance.value("config_hash", "")},
                   {"num_steps", index.num_steps},
                   {"shards", shards}});
  }
  return out;
}

}  // namespace wm::tokenize

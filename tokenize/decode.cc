#include "tokenize/decode.h"

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/shard/dataset_reader.h"
#include "core/tokens/token_dataset.h"
#include "tokenize/frame_sampler.h"
#include "tokenize/mp4_writer.h"
#include "tokenize/tokenizer.h"

namespace wm::tokenize {
namespace fs = std::filesystem;
namespace {

// [T, 3, S, S] planar floats -> T BGR images for OpenCV.
std::vector<cv::Mat> ToBgr(const std::vector<float>& frames, int size) {
  const size_t floats = 3ull * size * size;
  std::vector<cv::Mat> out;
  for (size_t t = 0; t < frames.size() / floats; ++t) {
    std::vector<uint8_t> rgb = PlanarToRgb8(frames.data() + t * floats, size);
    cv::Mat bgr;
    cv::cvtColor(cv::Mat(size, size, CV_8UC3, rgb.data()), bgr, cv::COLOR_RGB2BGR);
    out.push_back(bgr);
  }
  return out;
}

// Rows of `columns` frames; with originals, each row of originals sits above its decoded row.
cv::Mat ContactSheet(const std::vector<cv::Mat>& decoded, const std::vector<cv::Mat>& originals,
                     int columns) {
  const int size = decoded.front().rows, n = static_cast<int>(decoded.size());
  const int rows = (n + columns - 1) / columns, bands = originals.empty() ? 1 : 2;
  cv::Mat sheet(rows * bands * size, std::min(n, columns) * size, CV_8UC3, cv::Scalar::all(0));
  for (int t = 0; t < n; ++t) {
    const int x = (t % columns) * size, y = (t / columns) * bands * size;
    if (!originals.empty()) originals[t].copyTo(sheet(cv::Rect(x, y, size, size)));
    decoded[t].copyTo(sheet(cv::Rect(x, y + (bands - 1) * size, size, size)));
  }
  return sheet;
}

void WriteImage(const std::string& path, const cv::Mat& image) {
  Check(cv::imwrite(path, image), "cannot write image", {.file = path});
}

}  // namespace

int64_t DecodeEpisode(const DecodeOptions& o) {
  tokens::TokenDataset data(o.tokens_dir);
  Tokenizer tok(o.checkpoint, o.device);
  Check(data.index().tokenizer.checkpoint_sha256 == tok.checkpoint_sha256(),
        "these tokens were written by another tokenizer (index.json tokenizer.checkpoint_sha256 "
        "differs from this checkpoint's)",
        {.file = tok.checkpoint_path()});
  const tokens::TokenEpisode& e = data.episode(o.episode);
  std::vector<int64_t> wide(static_cast<size_t>(e.num_frames * data.tokens_per_frame()));
  data.CopyTokens(o.episode, 0, e.num_frames, wide.data());
  std::vector<uint32_t> codes(wide.begin(), wide.end());

  std::vector<float> planar;  // the originals, [frames, 3, S, S]
  const size_t floats = 3ull * tok.image_size() * tok.image_size();
  if (!o.originals_dir.empty()) {
    shard::DatasetReader source(o.originals_dir);
    Episode src = source.ReadEpisode(static_cast<size_t>(e.source_episode));
    const auto& frames = src.images.at(data.index().tokenizer.image_key).frames;
    Check(static_cast<int64_t>(frames.size()) == e.num_frames,
          "source episode has a different frame count", {.file = o.originals_dir});
    planar.resize(frames.size() * floats);
    for (size_t t = 0; t < frames.size(); ++t) {
      DecodeFrame(frames[t], tok.image_size(), planar.data() + t * floats);
    }
  }
  // An anchored tokenizer decodes every frame with the first original as its anchor, as
  // wm-eval decodes a rollout from that frame (its copy_last_tokens is frame 0 decoded so);
  // without --originals, from the tokens alone.
  std::vector<float> anchors;
  if (tok.anchored() && !planar.empty()) {
    for (int64_t t = 0; t < e.num_frames; ++t) {
      anchors.insert(anchors.end(), planar.begin(), planar.begin() + floats);
    }
  }
  std::vector<cv::Mat> decoded =
      ToBgr(tok.Decode(codes.data(), e.num_frames, anchors.empty() ? nullptr : anchors.data()),
            tok.image_size());
  std::vector<cv::Mat> originals;
  if (!planar.empty()) originals = ToBgr(planar, tok.image_size());

  const std::string ext = fs::path(o.out).extension().string();
  if (ext == ".png") {
    WriteImage(o.out, ContactSheet(decoded, originals, o.columns));
  } else if (ext == ".mp4") {
    const int size = tok.image_size(), width = originals.empty() ? size : 2 * size;
    Mp4Writer video(o.out, 10.0, width, size);
    for (size_t t = 0; t < decoded.size(); ++t) {
      cv::Mat frame = decoded[t];
      if (!originals.empty()) cv::hconcat(originals[t], decoded[t], frame);
      video.Write(frame);
    }
    video.Commit();
  } else {
    fs::create_directories(o.out);
    for (size_t t = 0; t < decoded.size(); ++t) {
      char name[32];
      std::snprintf(name, sizeof(name), "frame_%04zu.png", t);
      WriteImage((fs::path(o.out) / name).string(), decoded[t]);
    }
  }
  return e.num_frames;
}

}  // namespace wm::tokenize

#include "metrics/image_io.h"

#include <algorithm>
#include <array>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <optional>

#include "core/error.h"

namespace wm::metrics {
namespace {
namespace fs = std::filesystem;

std::string LowerExtension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

bool IsImageFile(const fs::path& path) {
  static const std::array<const char*, 11> kExtensions = {
      ".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp", ".ppm", ".pgm", ".pnm", ".exr"};
  const std::string ext = LowerExtension(path.string());
  return std::find(kExtensions.begin(), kExtensions.end(), ext) != kExtensions.end();
}

// An OpenCV matrix (1, 3 or 4 channels, BGR order) as an RGB or grey Image.
Image FromMat(const cv::Mat& decoded, const std::string& source) {
  cv::Mat mat;
  switch (decoded.channels()) {
    case 1:
      mat = decoded;
      break;
    case 3:
      cv::cvtColor(decoded, mat, cv::COLOR_BGR2RGB);
      break;
    case 4:
      cv::cvtColor(decoded, mat, cv::COLOR_BGRA2RGB);
      break;
    default:
      throw Error("unsupported channel count " + std::to_string(decoded.channels()) +
                      " (expected grey, RGB or RGBA)",
                  {.file = source});
  }
  double range = 0;
  switch (mat.depth()) {
    case CV_8U:
      range = 255.0;
      break;
    case CV_16U:
      range = 65535.0;
      break;
    case CV_32F:
      range = 1.0;
      break;
    default:
      throw Error("unsupported pixel depth (expected 8-bit, 16-bit or float)", {.file = source});
  }
  cv::Mat values;
  mat.convertTo(values, CV_64F);
  values = values.isContinuous() ? values : values.clone();
  return Image::FromDouble(values.ptr<double>(), values.rows, values.cols, values.channels(),
                           range);
}

void CheckSameShapeAs(const Image& first, const std::string& first_source, const Image& image,
                      const std::string& source) {
  try {
    CheckSameShape(first, image);
  } catch (const Error& e) {
    throw Error(e.message() + " (" + first_source + " vs this file)", {.file = source});
  }
}

}  // namespace

Image LoadImage(const std::string& path) {
  Check(fs::is_regular_file(path), "image file not found", {.file = path});
  cv::Mat decoded = cv::imread(path, cv::IMREAD_UNCHANGED);
  Check(!decoded.empty(), "cannot decode image (corrupt or unsupported format)", {.file = path});
  return FromMat(decoded, path);
}

Image DecodeImage(const std::string& bytes, const std::string& source) {
  const cv::Mat raw(1, static_cast<int>(bytes.size()), CV_8U,
                    const_cast<char*>(bytes.data()));  // imdecode only reads it
  cv::Mat decoded = cv::imdecode(raw, cv::IMREAD_UNCHANGED);
  Check(!decoded.empty(), "cannot decode image (corrupt or unsupported format)", {.file = source});
  return FromMat(decoded, source);
}

std::vector<std::string> ListImageFiles(const std::string& folder) {
  Check(fs::is_directory(folder), "not a folder", {.file = folder});
  std::vector<std::string> files;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(folder, ec)) {
    if (entry.is_regular_file() && IsImageFile(entry.path()))
      files.push_back(entry.path().string());
  }
  Check(!ec, "cannot list folder: " + ec.message(), {.file = folder});
  Check(!files.empty(), "folder holds no image files (.png, .jpg, ...)", {.file = folder});
  std::sort(files.begin(), files.end());
  return files;
}

bool IsVideoFile(const std::string& path) {
  static const std::array<const char*, 11> kExtensions = {
      ".mp4", ".avi", ".mov", ".mkv", ".webm", ".m4v", ".mpg", ".mpeg", ".wmv", ".flv", ".gif"};
  const std::string ext = LowerExtension(path);
  return std::find(kExtensions.begin(), kExtensions.end(), ext) != kExtensions.end();
}

struct FrameStream::State {
  std::string path;
  std::vector<std::string> files;  // folder or single image; empty for a video
  size_t next = 0;
  cv::VideoCapture video;
  bool is_video = false;
  std::optional<Image> first;  // shape every later frame must have
  std::string first_source;
};

FrameStream::FrameStream(const std::string& path) : s_(std::make_unique<State>()) {
  s_->path = path;
  if (fs::is_directory(path)) {
    s_->files = ListImageFiles(path);
  } else if (IsVideoFile(path)) {
    s_->is_video = true;
    s_->video.open(path);
    if (!s_->video.isOpened()) {
      throw Error("cannot open video (missing, not a video, or no decoder for its codec)",
                  {.file = path});
    }
  } else {
    s_->files = {path};
  }
}

FrameStream::~FrameStream() = default;

const std::string& FrameStream::path() const { return s_->path; }

size_t FrameStream::Read(size_t max_frames, Frames* out) {
  size_t read = 0;
  for (; read < max_frames; ++read) {
    Image image;
    std::string source;
    if (s_->is_video) {
      cv::Mat frame;
      if (!s_->video.read(frame) || frame.empty()) break;
      source = s_->path + "#frame " + std::to_string(s_->next++);
      image = FromMat(frame, source);
    } else {
      if (s_->next == s_->files.size()) break;
      source = s_->files[s_->next++];
      image = LoadImage(source);
    }
    if (!s_->first) {
      s_->first = image;
      s_->first_source = source;
    }
    CheckSameShapeAs(*s_->first, s_->first_source, image, source);
    out->images.push_back(std::move(image));
    out->sources.push_back(std::move(source));
  }
  Check(!(s_->is_video && s_->next == 0 && read == 0 && max_frames > 0),
        "video has no decodable frame", {.file = s_->path});
  return read;
}

Frames LoadFrames(const std::string& path) {
  FrameStream stream(path);
  Frames frames;
  while (stream.Read(256, &frames) > 0) {
  }
  return frames;
}

void CheckPaired(const Frames& a, const Frames& b) {
  Check(a.images.size() == b.images.size(),
        "frame counts differ: " + std::to_string(a.images.size()) + " (" +
            (a.sources.empty() ? "" : a.sources[0]) + ", ...) vs " +
            std::to_string(b.images.size()) + " (" + (b.sources.empty() ? "" : b.sources[0]) +
            ", ...)");
  for (size_t i = 0; i < a.images.size(); ++i) {
    CheckSameShapeAs(b.images[i], b.sources[i], a.images[i], a.sources[i]);
  }
}

}  // namespace wm::metrics

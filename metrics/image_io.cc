#include "metrics/image_io.h"

#include <algorithm>
#include <array>
#include <filesystem>
#include <optional>

#include "core/error.h"
#include "core/image_codec.h"
#include "metrics/image_decoder.h"

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

void CheckSameShapeAs(const Image& first, const std::string& first_source, const Image& image,
                      const std::string& source) {
  try {
    CheckSameShape(first, image);
  } catch (const Error& e) {
    throw Error(e.message() + " (" + first_source + " vs this file)", {.file = source});
  }
}

}  // namespace

namespace internal {

Image FromDecodedImage(const DecodedImage& d) {
  if (d.bit_depth == 8) return Image::FromUint8(d.data.data(), d.height, d.width, d.channels);
  std::vector<double> values(d.data.size() / 2);
  for (size_t i = 0; i < values.size(); ++i) values[i] = d.samples16()[i];
  return Image::FromDouble(values.data(), d.height, d.width, d.channels, 65535.0);
}

}  // namespace internal

Image LoadImage(const std::string& path) {
  Check(fs::is_regular_file(path), "image file not found", {.file = path});
  return internal::ReadImageFile(path);
}

Image DecodeImage(const std::string& bytes, const std::string& source) {
  return internal::DecodeImageBytes(bytes, source);
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
  std::unique_ptr<internal::VideoDecoder> video;  // null unless a video
  std::optional<Image> first;                     // shape every later frame must have
  std::string first_source;
};

FrameStream::FrameStream(const std::string& path) : s_(std::make_unique<State>()) {
  s_->path = path;
  if (fs::is_directory(path)) {
    s_->files = ListImageFiles(path);
  } else if (IsVideoFile(path)) {
    s_->video = std::make_unique<internal::VideoDecoder>(path);
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
    if (s_->video) {
      source = s_->path + "#frame " + std::to_string(s_->next);
      if (!s_->video->Next(source, &image)) break;
      ++s_->next;
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
  Check(!(s_->video && s_->next == 0 && read == 0 && max_frames > 0),
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

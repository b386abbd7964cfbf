#include "evaluate/episode_strip.h"

#include <algorithm>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/atomic_file.h"
#include "core/error.h"
#include "evaluate/frame_image.h"

namespace wm::evaluate {
namespace {

const cv::Scalar kBackground(40, 40, 40), kText(235, 235, 235);
constexpr const char* kModelRollouts[] = {"plain", "retrace"};
constexpr const char* kBaselines[] = {"copy_last", "copy_last_tokens", "tokenizer_recon"};
constexpr const char* kErrorPrefix = "error ";

// Draws `lines` left-aligned in `box`, vertically centred, shrinking the font until the widest
// line fits (Hershey fonts: no font files needed, the same pixels everywhere).
void DrawLabel(cv::Mat& canvas, const cv::Rect& box, const std::vector<std::string>& lines) {
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  double scale = 0.5;
  int line_height = 0, baseline = 0;
  for (; scale > 0.2; scale -= 0.05) {
    int widest = 0;
    for (const auto& l : lines) {
      const cv::Size s = cv::getTextSize(l, font, scale, 1, &baseline);
      widest = std::max(widest, s.width);
      line_height = s.height + baseline + 4;
    }
    if (widest <= box.width - 8) break;
  }
  int y = box.y + (box.height - line_height * static_cast<int>(lines.size())) / 2;
  for (const auto& l : lines) {
    y += line_height;
    cv::putText(canvas, l, {box.x + 4, y - baseline - 2}, font, scale, kText, 1, cv::LINE_AA);
  }
}

// The cells of one row, frames 0..H, before upscaling.
std::vector<cv::Mat> RowCells(const std::string& row, const Clip& real,
                              const std::map<std::string, Clip>& clips) {
  std::vector<cv::Mat> cells = {ClipFrameBgr(real, 0)};
  if (row.rfind(kErrorPrefix, 0) == 0) {
    const Clip& pred = clips.at(row.substr(std::string(kErrorPrefix).size()));
    cells[0] = ErrorHeatMap(cells[0], cells[0]);  // frame 0 is given: no error
    for (int64_t t = 1; t < real.frames; ++t) {
      cells.push_back(ErrorHeatMap(ClipFrameBgr(real, t), ClipFrameBgr(pred, t - 1)));
    }
    return cells;
  }
  for (int64_t t = 1; t < real.frames; ++t) {
    cells.push_back(row == "real" ? ClipFrameBgr(real, t) : ClipFrameBgr(clips.at(row), t - 1));
  }
  return cells;
}

std::vector<std::string> RowLabel(const std::string& row) {
  if (row.rfind(kErrorPrefix, 0) == 0) return {row, "|real - pred|", "x3, blue..red"};
  return {row};
}

void WritePng(const std::string& path, const cv::Mat& image) {
  std::vector<uchar> png;
  Check(cv::imencode(".png", image, png), "cannot encode the picture as PNG", {.file = path});
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  WriteFileAtomically(path,
                      std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
}

}  // namespace

int StripScale(int size) { return std::max(1, (192 + size - 1) / size); }

std::vector<std::string> StripRows(const std::map<std::string, Clip>& clips) {
  std::vector<std::string> rows = {"real"}, fixed = {"real"};
  for (const char* k : kModelRollouts) {
    if (clips.count(k)) rows.push_back(k);
  }
  const std::string error_of = rows.size() > 1 ? rows[1] : "";
  for (const char* k : kModelRollouts) fixed.push_back(k);
  for (const char* k : kBaselines) {
    fixed.push_back(k);
    if (clips.count(k)) rows.push_back(k);
  }
  for (const auto& [kind, clip] : clips) {
    if (std::find(fixed.begin(), fixed.end(), kind) == fixed.end()) rows.push_back(kind);
  }
  if (!error_of.empty()) rows.push_back(kErrorPrefix + error_of);
  return rows;
}

void WriteEpisodeStrip(const std::string& dir, int64_t episode, const Clip& real,
                       const std::map<std::string, Clip>& clips) {
  const std::vector<std::string> rows = StripRows(clips);
  const int columns = static_cast<int>(real.frames);
  const int cell = real.size * StripScale(real.size);
  const auto extent = [&](int n) { return n * cell + (n - 1) * kStripGap; };
  cv::Mat canvas(kStripHeaderHeight + extent(static_cast<int>(rows.size())),
                 kStripLabelWidth + extent(columns), CV_8UC3, kBackground);
  for (int c = 0; c < columns; ++c) {
    DrawLabel(canvas, {kStripLabelWidth + c * (cell + kStripGap), 0, cell, kStripHeaderHeight},
              {c == 0 ? "0 (given)" : "step " + std::to_string(c)});
  }
  for (size_t r = 0; r < rows.size(); ++r) {
    const int y = kStripHeaderHeight + static_cast<int>(r) * (cell + kStripGap);
    DrawLabel(canvas, {0, y, kStripLabelWidth, cell}, RowLabel(rows[r]));
    const std::vector<cv::Mat> cells = RowCells(rows[r], real, clips);
    for (int c = 0; c < columns; ++c) {
      const cv::Rect box(kStripLabelWidth + c * (cell + kStripGap), y, cell, cell);
      cv::resize(cells[c], canvas(box), box.size(), 0, 0, cv::INTER_NEAREST);
    }
  }
  WritePng((std::filesystem::path(dir) / ("episode_" + std::to_string(episode) + ".png")).string(),
           canvas);
}

void WriteStripOverview(const std::string& dir, const std::vector<int64_t>& episodes, int count,
                        int size) {
  const int cell = size * StripScale(size);
  std::vector<std::pair<int64_t, cv::Mat>> strips;
  for (size_t i = 0; i < episodes.size() && static_cast<int>(i) < count; ++i) {
    const std::string path =
        (std::filesystem::path(dir) / ("episode_" + std::to_string(episodes[i]) + ".png")).string();
    if (!std::filesystem::exists(path)) continue;
    strips.emplace_back(episodes[i], cv::imread(path, cv::IMREAD_COLOR));
    Check(!strips.back().second.empty(), "cannot read the strip back", {.file = path});
  }
  if (strips.empty()) return;
  // Episodes shorter than the horizon have fewer columns: the header comes from the widest
  // strip and narrower rows are padded on the right.
  const cv::Mat& widest = std::max_element(strips.begin(), strips.end(), [](auto& a, auto& b) {
                            return a.second.cols < b.second.cols;
                          })->second;
  const auto padded = [&](const cv::Mat& part) {
    cv::Mat out;
    cv::copyMakeBorder(part, out, 0, 0, 0, widest.cols - part.cols, cv::BORDER_CONSTANT,
                       kBackground);
    return out;
  };
  std::vector<cv::Mat> parts = {widest.rowRange(0, kStripHeaderHeight).clone()};
  for (const auto& [episode, strip] : strips) {
    const int rows = (strip.rows - kStripHeaderHeight + kStripGap) / (cell + kStripGap);
    for (int r : {0, 1, rows - 1}) {  // real, the first model rollout, its error
      const int y = kStripHeaderHeight + r * (cell + kStripGap);
      cv::Mat row = padded(strip.rowRange(y, std::min(strip.rows, y + cell + kStripGap)));
      cv::putText(row, "episode " + std::to_string(episode), {4, 16}, cv::FONT_HERSHEY_SIMPLEX,
                  0.45, kText, 1, cv::LINE_AA);
      parts.push_back(row);
    }
    parts.back().push_back(cv::Mat(3 * kStripGap, widest.cols, CV_8UC3, kBackground));
  }
  cv::Mat overview;
  cv::vconcat(parts, overview);
  WritePng((std::filesystem::path(dir) / "overview.png").string(), overview);
}

}  // namespace wm::evaluate

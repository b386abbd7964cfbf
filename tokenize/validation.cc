#include "tokenize/validation.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "core/image_codec.h"
#include "metrics/image.h"
#include "metrics/pixel_metrics.h"
#include "tokenize/tokenizer.h"

namespace wm::tokenize {

double FlickerCounts::flicker() const {
  return changes ? static_cast<double>(static_changes) / static_cast<double>(changes) : 0.0;
}

double FlickerCounts::change_rate() const {
  return cells ? static_cast<double>(changes) / static_cast<double>(cells) : 0.0;
}

FlickerCounts& FlickerCounts::operator+=(const FlickerCounts& o) {
  static_changes += o.static_changes;
  changes += o.changes;
  cells += o.cells;
  return *this;
}

namespace {

// Whether some pixel of cell (cy, cx) changed (PixelChanged) between a and b.
bool CellChanged(const uint8_t* a, const uint8_t* b, int size, int cell, int cy, int cx) {
  for (int y = cy * cell; y < (cy + 1) * cell; ++y) {
    const size_t row = static_cast<size_t>(y) * size;
    for (int x = cx * cell; x < (cx + 1) * cell; ++x) {
      if (PixelChanged(a + (row + x) * 3, b + (row + x) * 3)) return true;
    }
  }
  return false;
}

}  // namespace

FlickerCounts CountFlicker(const int64_t* codes, const uint8_t* rgb, int64_t frames, int size,
                           int grid) {
  const int cell = size / grid;
  const size_t frame_bytes = 3ull * size * size, frame_codes = static_cast<size_t>(grid) * grid;
  FlickerCounts n;
  for (int64_t t = 1; t < frames; ++t) {
    const int64_t* prev = codes + (t - 1) * frame_codes;
    const int64_t* cur = codes + t * frame_codes;
    for (int cy = 0; cy < grid; ++cy) {
      for (int cx = 0; cx < grid; ++cx) {
        ++n.cells;
        const size_t k = static_cast<size_t>(cy) * grid + cx;
        if (prev[k] == cur[k]) continue;
        ++n.changes;
        if (!CellChanged(rgb + (t - 1) * frame_bytes, rgb + t * frame_bytes, size, cell, cy, cx))
          ++n.static_changes;
      }
    }
  }
  return n;
}

ReconstructionScore ScoreReconstruction(const float* original, const float* recon, int64_t n,
                                        int size) {
  const size_t floats = 3ull * size * size;
  ReconstructionScore score;
  int64_t finite = 0;
  double l1 = 0;
  for (int64_t i = 0; i < n; ++i) {
    const float* a = original + i * floats;
    const float* b = recon + i * floats;
    for (size_t j = 0; j < floats; ++j) l1 += std::abs(std::clamp(b[j], -1.f, 1.f) - a[j]);
    auto ref = metrics::Image::FromUint8(PlanarToRgb8(a, size).data(), size, size, 3);
    auto pred = metrics::Image::FromUint8(PlanarToRgb8(b, size).data(), size, size, 3);
    const double psnr = metrics::Psnr(ref, pred);
    if (std::isfinite(psnr)) {
      score.psnr += psnr;
      ++finite;
    }
    score.ssim += metrics::Ssim(ref, pred);
  }
  score.psnr = finite ? score.psnr / finite : INFINITY;
  score.ssim /= static_cast<double>(n);
  score.l1 = l1 / (static_cast<double>(n) * floats);
  return score;
}

ImageSummary ReconstructionSheet(const std::string& tag, const float* original, const float* recon,
                                 int64_t n, int size, int columns) {
  const int count = static_cast<int>(std::min<int64_t>(n, columns));
  const size_t row_bytes = static_cast<size_t>(count) * size * 3;  // one pixel row of the sheet
  std::vector<uint8_t> sheet(2 * size * row_bytes);
  const size_t frame_floats = 3ull * size * size;
  for (int band = 0; band < 2; ++band) {
    const float* frames = band == 0 ? original : recon;
    for (int k = 0; k < count; ++k) {
      const std::vector<uint8_t> rgb = PlanarToRgb8(frames + k * frame_floats, size);
      for (int y = 0; y < size; ++y) {
        std::copy_n(rgb.data() + static_cast<size_t>(y) * size * 3, size * 3,
                    sheet.data() + (band * size + y) * row_bytes + k * size * 3);
      }
    }
  }
  return {tag, 2 * size, count * size, 3, EncodePng(sheet.data(), 2 * size, count * size, 3)};
}

}  // namespace wm::tokenize

#pragma once
// Reconstruction quality of the tokenizer, scored with the wmkit metrics library on the uint8
// frames a user would see (so val PSNR/SSIM match `wm-metrics` on exported PNGs).
#include <cstdint>
#include <string>

#include "core/tensorboard_events.h"

namespace wm::tokenize {

struct ReconstructionScore {
  double psnr = 0;  // mean over frames of PSNR (data range 255); +inf frames are skipped
  double ssim = 0;  // mean over frames of SSIM (scikit-image's gaussian convention)
  double l1 = 0;    // mean |recon - original| in [-1, 1] units, as in the training loss
  // Over the validation episodes (FlickerCounts): 0 when no episode was scored.
  double flicker = 0;            // share of token changes that no pixel change explains
  double token_change_rate = 0;  // token changes per cell and frame pair
};

// A pixel "really changed" between two frames when some channel differs by more than this many
// levels (0..255): the rule of issue 20's flicker and motion measurements (also wm-eval's
// moved_error_ratio). A cell changed when one of its pixels did.
inline constexpr int kChangedLevels = 30;
// `a`, `b`: one pixel of interleaved RGB uint8 frames.
inline bool PixelChanged(const uint8_t* a, const uint8_t* b) {
  for (int c = 0; c < 3; ++c) {
    if (a[c] - b[c] > kChangedLevels || b[c] - a[c] > kChangedLevels) return true;
  }
  return false;
}

// Token flicker (issue 20): a token that changes between consecutive frames in a cell whose
// pixels did not change is noise a dynamics model cannot predict (and argmax over near-synonym
// codes decodes to a blur). Counts over consecutive frame pairs of episodes.
struct FlickerCounts {
  int64_t static_changes = 0;  // token changes in cells where no pixel changed
  int64_t changes = 0;         // all token changes
  int64_t cells = 0;           // cells compared: frame pairs x grid x grid
  // static_changes / changes (0 when nothing changed: no flicker).
  double flicker() const;
  // changes / cells (0 when nothing was compared).
  double change_rate() const;
  FlickerCounts& operator+=(const FlickerCounts& other);
};

// One episode: codes [frames, grid, grid] and its frames as interleaved RGB uint8
// [frames, size, size, 3], size a multiple of grid (a cell is size/grid pixels square).
FlickerCounts CountFlicker(const int64_t* codes, const uint8_t* rgb, int64_t frames, int size,
                           int grid);

// original, recon: [n, 3, size, size] planar floats in [-1, 1].
ReconstructionScore ScoreReconstruction(const float* original, const float* recon, int64_t n,
                                        int size);

// The first min(n, columns) frames above their reconstructions, one PNG tagged `tag` for
// TensorBoard: RGB, 2 * size rows by columns * size. Planar floats in [-1, 1] as above.
ImageSummary ReconstructionSheet(const std::string& tag, const float* original, const float* recon,
                                 int64_t n, int size, int columns);

}  // namespace wm::tokenize

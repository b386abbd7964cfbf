#pragma once
// Reconstruction quality of the tokenizer, scored with the wmkit metrics library on the uint8
// frames a user would see (so val PSNR/SSIM match `wm-metrics` on exported PNGs).
#include <cstdint>

namespace wm::tokenize {

struct ReconstructionScore {
  double psnr = 0;  // mean over frames of PSNR (data range 255); +inf frames are skipped
  double ssim = 0;  // mean over frames of SSIM (scikit-image's gaussian convention)
  double l1 = 0;    // mean |recon - original| in [-1, 1] units, as in the training loss
};

// original, recon: [n, 3, size, size] planar floats in [-1, 1].
ReconstructionScore ScoreReconstruction(const float* original, const float* recon, int64_t n,
                                        int size);

}  // namespace wm::tokenize

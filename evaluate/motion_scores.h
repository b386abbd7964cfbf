#pragma once
// Per-step scores that a frozen or blurred prediction cannot win (issue #20, docs/reports.md):
// the controllability difference ΔtPSNR (evaluate/controllability.h makes the perturbed
// rollout) and the moved-region error ratio. Pure functions of clips, on the uint8 frames the
// other pixel metrics use (frame_scores.h).
#include <vector>

#include "evaluate/frame_scores.h"

namespace wm::evaluate {

// PSNR (dB, R = 255) per frame, as ScoreFrames' "psnr": +inf for identical frames.
std::vector<double> FramePsnr(const Clip& real, const Clip& pred);

// Genie's ΔtPSNR per step: psnr[t] - psnr_perturbed[t]. Equal values give exactly 0 (also two
// +inf: a prediction that did not change); a single infinity gives NaN (undefined).
std::vector<double> DeltaPsnr(const std::vector<double>& psnr,
                              const std::vector<double>& psnr_perturbed);

// moved_error_ratio per step t: over the pixels that moved between `first` (frame 0 of a clip:
// the last real context frame) and real frame t (tokenize::PixelChanged: any channel > 30 levels
// apart), the mean |pred - real| divided by the mean |pred - first|, over those pixels' 3 channels.
// < 1: the prediction is nearer the truth than the start there (it moved the right way); a copy of
// the first frame is undefined (0 in the denominator), one near it scores well above 1. NaN when no
// pixel moved or the denominator is 0.
std::vector<double> MovedErrorRatio(const Clip& first, const Clip& real, const Clip& pred);

}  // namespace wm::evaluate

#pragma once
// Internal to wm_metrics: the vectorised loops behind the pixel metrics. The SSIM statistics
// (Wang et al. 2004) are filtered exactly as scikit-image 0.19 does with gaussian_weights=True,
// sigma=1.5, use_sample_covariance=False: scipy.ndimage.gaussian_filter, truncate=3.5 (11 taps),
// mode 'reflect', first along rows (axis 0) then along columns (axis 1), each channel on its own.
#include <cstddef>
#include <vector>

namespace wm::metrics::internal {

constexpr int kSsimRadius = 5;  // int(3.5 * 1.5 + 0.5), as scipy.ndimage computes the radius
constexpr int kSsimWindow = 2 * kSsimRadius + 1;
constexpr double kSsimK1 = 0.01;  // Wang et al. 2004, eq. 7
constexpr double kSsimK2 = 0.03;  // Wang et al. 2004, eq. 9
constexpr int kMaxChannels = 3;

// A read-only HxWxC interleaved pixel array: an Image's pixels or a downsampled copy. Rows are
// filtered with their channels interleaved, so no per-channel copies are made.
struct GridView {
  int height = 0;
  int width = 0;
  int channels = 0;
  const double* values = nullptr;
};

struct Grid {
  int height = 0;
  int width = 0;
  int channels = 0;
  std::vector<double> values;
  GridView view() const { return {height, width, channels, values.data()}; }
};

// sum_i (a[i] - b[i])^2, MSE's numerator.
double SumSquaredDifference(const double* a, const double* b, size_t n);

// 2x2 average pooling (MS-SSIM's low-pass and downsample step); an odd last row/column is dropped.
Grid Downsample2x2(const GridView& grid);

// scipy.ndimage's 'reflect' boundary (d c b a | a b c d | d c b a) for index i of n samples.
int ReflectIndex(int i, int n);

// Per-channel sums over one row of the SSIM map and of the contrast-structure map
// cs = (2 s_xy + C2) / (s_x^2 + s_y^2 + C2), over columns [kSsimRadius, width - kSsimRadius).
struct SsimRowSums {
  double ssim[kMaxChannels] = {0, 0, 0};
  double cs[kMaxChannels] = {0, 0, 0};
};

// The SSIM statistics of output rows y .. y + rows - 1 (rows <= kMaxRows) of `a` and `b` (same
// shape, width >= kSsimWindow) with C1 = (K1 R)^2, C2 = (K2 R)^2, into sums[0 .. rows). Writes
// the SSIM map of each whole row (width * channels values, interleaved) to map_rows[r] when
// `map_rows` is not null; cs is only summed when `want_cs`. Rows go in pairs: two neighbours
// read 12 input rows together instead of 22 apart, and square each input once.
constexpr int kMaxRows = 2;
void SsimRows(const GridView& a, const GridView& b, int y, int rows, double c1, double c2,
              bool want_cs, double* const* map_rows, SsimRowSums* sums);

}  // namespace wm::metrics::internal

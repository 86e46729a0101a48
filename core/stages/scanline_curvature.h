// SPDX-License-Identifier: Apache-2.0
// Discrete scanline curvature (docs/algorithms.md §9): the practical equivalent of the paper's
// per-scanline NURBS, a Gaussian-weighted quadratic fitted in a window along each scanline.
#pragma once

#include <cstddef>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/cancel.h"
#include "core/base/point_cloud.h"

namespace scanprep {

// Δp per scan: the median distance between consecutive unremoved points of a scanline; 0 for a
// scan without scanlines.
// In parallel; CANCELLED when `cancel` fires.
absl::StatusOr<std::vector<double>> MedianScanlineSpacing(const PointCloud& cloud,
                                                          const CancelToken& cancel);

// A window holds at most this many points on each side of its centre, whatever its half-width:
// a half-width far beyond the data's scale (a window_mm given in the wrong unit) would otherwise
// make every fit walk the whole scanline, O(L²) per line.
inline constexpr size_t kMaxWindowSide = 128;

struct ScanlineCurvatureCounts {
  size_t windows_capped = 0;  // windows cut to kMaxWindowSide points on a side
  size_t window_points = 0;   // points summed over all fits: the work, <= (2·kMaxWindowSide+1)·n
};

// Per point, from its scanline window, so that a caller can judge κ against the scan's noise σ:
// - kappa: κ (mm⁻¹);
// - noise_per_sigma: the standard deviation κ would have on a straight line with unit noise
//   across it (κ's noise per mm of σ);
// - misfit (mm²): the σ² at which the quadratic's residual would be the 99.9 % extreme of noise;
//   above the scan's σ², the window is no smooth curve (a kink: an edge, not a bore or a fillet).
// NaN where no window exists.
struct ScanlineCurvatures {
  std::vector<float> kappa;
  std::vector<float> noise_per_sigma;
  std::vector<float> misfit;
};

// κ for every point whose scanline window holds >= 2 points on each side; NaN elsewhere
// (removed points, segment ends, clouds without scanlines). Lines are split at gaps > 3·Δp_ℓ and
// the window is |arc offset| <= window[scan], at most kMaxWindowSide points a side, with
// weights exp(−x²/(2(h/2)²)).
absl::Status ScanlineCurvature(const PointCloud& cloud, const std::vector<double>& window,
                               const CancelToken& cancel, ScanlineCurvatures& out,
                               ScanlineCurvatureCounts& counts);

}  // namespace scanprep

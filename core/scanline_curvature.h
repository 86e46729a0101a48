// Discrete scanline curvature (algorithms.md §9): the practical equivalent of the paper's
// per-scanline NURBS, a Gaussian-weighted quadratic fitted in a window along each scanline.
#pragma once

#include <vector>

#include "absl/status/status.h"
#include "core/cancel.h"
#include "core/point_cloud.h"

namespace scanprep {

// Δp per scan: the median distance between consecutive unremoved points of a scanline; 0 for a
// scan without scanlines.
std::vector<double> MedianScanlineSpacing(const PointCloud& cloud);

// κ (mm⁻¹) for every point whose scanline window holds >= 2 points on each side; NaN elsewhere
// (removed points, segment ends, clouds without scanlines). Lines are split at gaps > 3·Δp_ℓ and
// the window is |arc offset| <= window[scan] with weights exp(−x²/(2(h/2)²)).
absl::Status ScanlineCurvature(const PointCloud& cloud, const std::vector<double>& window,
                               const CancelToken& cancel, std::vector<float>& kappa);

}  // namespace scanprep

// SPDX-License-Identifier: Apache-2.0
// How one scan lies against another where they overlap: the signed point-to-plane residuals of
// the moving scan's points against the fixed scan's local planes, and the rigid misalignment
// they imply, with each component's standard error; a component the overlap's shape does not
// constrain to a share of the noise is flagged (docs/health.md).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "absl/status/statusor.h"
#include "core/base/cancel.h"
#include "core/base/point_cloud.h"
#include "core/stages/health_report.h"

namespace scanprep {

// A point of the moving scan and the fixed scan's local plane it is measured against: the plane
// of fixed point `fixed`'s own-scan neighbourhood, with unit normal `normal` (fixed's orientation)
// and `plane_offset` = normal·(plane point − p_fixed). `sigma`: the residual's expected noise
// (mm), from the two points' own fit residuals; the solve weights by 1/sigma², so a face seen at
// a grazing angle (noise σ/cos q) does not drown the rest.
struct Correspondence {
  uint32_t moving = 0, fixed = 0;
  Eigen::Vector3f normal = Eigen::Vector3f::UnitZ();
  float plane_offset = 0;
  float sigma = 1;
};

struct MisalignmentSettings {
  size_t min_points = 1000;  // fewer correspondences: nothing is constrained
  // A component whose standard error exceeds this share of the pair's residual spread is
  // unconstrained (rotations as lengths at the overlap's extent).
  double max_standard_error = 0.05;
};

// The robust spread of residuals whose median absolute deviation is `mad`: 1.4826·MAD, which is
// σ for normally distributed residuals.
inline double RobustSpread(double mad) { return 1.4826 * mad; }

// The pair's report from its correspondences (any order; the result does not depend on it beyond
// rounding). Coordinates are taken relative to the overlap's centroid in double.
// Its sums run in parallel, in fixed blocks (the same result on any number of threads); CANCELLED
// when `cancel` fires.
// `equations`, when given, receives the normal equations of the second pass in the pair's frame
// (rotations about `PairHealth::centre`, scaled by the overlap's extent), for a solve over many
// scans at once (registration.cc); left as it was for a pair too small to be solved.
struct PairEquations {
  Eigen::Matrix<double, 6, 6> h = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
  double extent = 0;  // the overlap's RMS extent (mm)
  // The robust spread of the whitened residuals the fit leaves (1 when the matches state their
  // noise rightly).
  double unit_spread = 0;
};
absl::StatusOr<PairHealth> EstimatePairHealth(const PointCloud& cloud, uint32_t fixed_scan,
                                              uint32_t moving_scan,
                                              std::span<const Correspondence> matches,
                                              const MisalignmentSettings& settings,
                                              const CancelToken& cancel,
                                              PairEquations* equations = nullptr);

// Least squares h x = g in the eigen-directions of h whose eigenvalue is not numerically zero; a
// component with a share in the others cannot be solved at all and is set to 0. How well each
// solved component is known is its variance, from `inverse`, not a rule about eigenvalue ratios: a
// weak direction that mixes two components inflates both their variances, however it is shared.
struct LeastSquares {
  Eigen::Matrix<double, 6, 1> x = Eigen::Matrix<double, 6, 1>::Zero();
  // h⁺ over the eigen-directions solved: x's covariance per unit residual variance.
  Eigen::Matrix<double, 6, 6> inverse = Eigen::Matrix<double, 6, 6>::Zero();
  std::array<bool, 6> solvable{};  // no share in a direction left out
};
LeastSquares SolveLeastSquares(const Eigen::Matrix<double, 6, 6>& h,
                               const Eigen::Matrix<double, 6, 1>& g);

}  // namespace scanprep

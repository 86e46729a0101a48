// SPDX-License-Identifier: Apache-2.0
// The normals stage's fit of one ball (paper Eq. 4): Gaussian weights exp(−‖p_j − p‖²/(2h²)) of
// the points `matches` holds, moments relative to the centre p. The one fit the normals stage and
// the own-scan noise measure (own_scan_noise.h) both make, so that their residuals compare.
#pragma once

#include <cmath>
#include <cstddef>

#include "core/base/point_cloud.h"
#include "core/spatial/cell_grid.h"
#include "core/spatial/local_moments.h"

namespace scanprep {

inline LocalFrame FitBall(const PointCloud& cloud, size_t i, double h,
                          const RadiusMatches& matches) {
  const double inv_two_h2 = h > 0 ? 1.0 / (2 * h * h) : 0.0;
  const Eigen::Vector3d p = cloud.point(i).cast<double>();
  MomentAccumulator moments;
  for (const auto& [j, d2] : matches) {
    // A weight needs no more than float precision, and expf is several times cheaper.
    const float w = std::exp(static_cast<float>(-d2 * inv_two_h2));
    moments.Add(cloud.point(j).cast<double>() - p, w);
  }
  return moments.Solve();
}

}  // namespace scanprep

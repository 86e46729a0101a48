// SPDX-License-Identifier: Apache-2.0
// The peers the metrology table compares against, each on the raw cloud: PCL's
// MovingLeastSquares and CGAL's bilateral_smooth_point_set. Each lives in its own file, compiled
// only where its library is installed (SCANPREP_HAVE_PCL / SCANPREP_HAVE_CGAL), never a
// dependency of the build or CI.
#pragma once

#include "core/base/point_cloud.h"

namespace scanprep::bench {

// `raw` with the peer's coordinates; a point the peer dropped is flagged kRemovedSimplify.
PointCloud SmoothWithPclMls(const PointCloud& raw, double radius_mm, int threads);

// Normals from jet_estimate_normals (k neighbours), oriented toward the scan's camera (what the
// sensor knows; CGAL's weights compare normal directions, so orientation matters), then
// `iterations` rounds of bilateral smoothing with k neighbours and the sharpness angle.
PointCloud SmoothWithCgalBilateral(const PointCloud& raw, int k, double sharpness_deg,
                                   int iterations);

}  // namespace scanprep::bench

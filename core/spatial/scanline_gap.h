// SPDX-License-Identifier: Apache-2.0
// A line scan's own scanline spacing, whatever its metadata says: how far a point's neighbouring
// scanline lies. The k-NN radius cannot tell it where points along a line are far closer than
// the lines (a laser-line sensor with 0.01 mm point pitch and profiles 1 mm apart has d_k =
// 0.1 mm, all k neighbours on the point's own line), so the check of r_min (Eq. 2) against the
// data's scale asks this as well as r_g.
#pragma once

#include <vector>

#include "absl/status/statusor.h"
#include "core/base/cancel.h"
#include "core/base/point_cloud.h"
#include "core/spatial/neighbourhoods.h"

namespace scanprep {

// Per scan s with reach[s] > 0: the median, over a sample of its points (one in 64, at most
// 256, evenly over the scan), of the distance to the nearest point of the same scan on another
// scanline, sought among the nearest 4·max_ball_points() within reach[s]. 0 for the other scans,
// when the cloud has no scanline indices, or when fewer than half the sampled points find one
// (a gap beyond reach, or points so dense along a line that its nearest are all its own).
// Bounded: at most 2·4·max_ball_points()/64 candidates read per point of a measured scan, in
// parallel; CANCELLED when `cancel` fires.
absl::StatusOr<std::vector<double>> ScanlineGaps(const PointCloud& cloud, const Neighbourhoods& nb,
                                                 const std::vector<double>& reach,
                                                 const CancelToken& cancel);

}  // namespace scanprep

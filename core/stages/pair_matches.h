// SPDX-License-Identifier: Apache-2.0
// The correspondences of overlapping scans, from the shared k-NN graph: each point of a moving
// scan with its partner in every lower-numbered scan and that partner's local plane. Health
// measures the misalignment they imply once; registration finds them again after every step.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/cancel.h"
#include "core/base/point_cloud.h"
#include "core/base/point_measures.h"
#include "core/spatial/neighbourhoods.h"
#include "core/stages/pair_misalignment.h"

namespace scanprep {

// Per scan, what the partner search needs: how far a partner may lie along its tangent plane
// (mm) and its spacing (the coarser of Δp and, for a line scanner, Δs).
struct PairSearch {
  std::vector<float> reach;
  std::vector<double> spacing;
};

// `max_pair_distance`: the reach in spacings.
absl::StatusOr<PairSearch> MakePairSearch(const PointCloud& cloud, const Neighbourhoods& nb,
                                          double max_pair_distance, const CancelToken& cancel);

// The correspondences of the moving scan whose points are `points`, per fixed scan (a lower-
// numbered one): each point with a normal fit, not removed as an outlier, with its partner in
// every lower-numbered scan: among its k-NN neighbours of that scan within the fixed scan's reach
// and offering a plane, the one nearest along its tangent plane. In the order of `points` (blocks
// kept by their start, so the sums do not depend on the threads).
absl::StatusOr<std::map<uint32_t, std::vector<Correspondence>>> FindCorrespondences(
    const PointCloud& cloud, const PointMeasures& m, const Neighbourhoods& nb,
    const PairSearch& search, std::span<const uint32_t> points, const CancelToken& cancel);

// The points of each scan, in index order (a counting sort).
std::vector<std::vector<uint32_t>> PointsPerScan(const PointCloud& cloud);

}  // namespace scanprep

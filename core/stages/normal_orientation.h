// SPDX-License-Identifier: Apache-2.0
// Normal orientation (docs/algorithms.md §7): toward the sensor with Eq. (3) when the scan knows
// where its sensor was, otherwise consistent propagation along a minimum spanning tree (Eq. 5,
// Hoppe).
#pragma once

#include <cstdint>
#include <optional>

#include <Eigen/Core>

#include "absl/status/status.h"
#include "core/base/cancel.h"
#include "core/base/point_cloud.h"
#include "core/spatial/neighbourhoods.h"

namespace scanprep {

// Direction from p toward the sensor of `scan`: camera centre, else projector/laser origin, else
// the constant view or projector direction of a sweeping scanner; nullopt when none is known.
std::optional<Eigen::Vector3d> TowardSensor(const ScanMeta& scan, const Eigen::Vector3d& p);

struct OrientationCounts {
  size_t toward_sensor = 0;  // oriented with Eq. (3)
  size_t propagated = 0;     // oriented along the spanning tree
  size_t bridges = 0;        // edges added to join k-NN graph components
  size_t bridge_work = 0;    // neighbours asked for by the bridging queries: O(components)
};

// Orients every valid normal of unremoved points in place. Points of scans without a sensor pose
// are oriented over the symmetric k-NN graph (first `k` neighbours) with edge cost
// 1 − |n_i·n_j| (+10⁻⁶·distance as a tie-break): Kruskal, then the components joined once by
// short edges between near components, then breadth-first flips from the highest point whose
// normal is set to n_z >= 0.
absl::Status OrientNormals(PointCloud& cloud, const Neighbourhoods& nb, uint32_t k,
                           const CancelToken& cancel, OrientationCounts& counts);

}  // namespace scanprep

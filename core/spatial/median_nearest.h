// SPDX-License-Identifier: Apache-2.0
// A scan's own spacing, whatever its metadata says: the median distance from each of its
// unremoved points to its nearest neighbour in the shared k-NN graph.
#pragma once

#include <vector>

#include "absl/status/statusor.h"
#include "core/base/cancel.h"
#include "core/base/point_cloud.h"
#include "core/spatial/neighbourhoods.h"

namespace scanprep {

// Per scan: the median nearest-neighbour distance of its unremoved points, for the scans where
// `wanted[s]` is true (every scan when `wanted` is empty); 0 where not wanted or without points.
// In parallel; CANCELLED when `cancel` fires.
absl::StatusOr<std::vector<double>> MedianNearestDistance(const PointCloud& cloud,
                                                          const Neighbourhoods& nb,
                                                          const CancelToken& cancel,
                                                          const std::vector<bool>& wanted = {});

}  // namespace scanprep

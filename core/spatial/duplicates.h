// SPDX-License-Identifier: Apache-2.0
// Exact duplicates: points of one scan with identical coordinates (scanners that repeat a point
// for a missing sample, clients that send a scan's points twice). Every stage sees each such group
// once, through its first point; the others are given that point's result on the way out. A pile of
// identical points would otherwise put thousands of candidates in one grid cell (k-NN quadratic
// in the pile) and hide a duplicated spike from the outlier rule (d₁ = 0).
#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "core/pipeline/cancel.h"
#include "core/point_cloud.h"

namespace scanprep {

struct DuplicateGroups {
  // Per input point: its group's index in the compacted cloud (groups in input order).
  std::vector<uint32_t> group_of;
  // Per group: how many input points it stands for.
  std::vector<uint32_t> multiplicity;
  // Input points at exactly the position of a point of a lower-numbered scan (a scan sent twice,
  // a registration that copied points): not collapsed, since each scan keeps its own points, but
  // counted so that the report can say so.
  size_t coincident_across_scans = 0;

  size_t collapsed() const { return group_of.size() - multiplicity.size(); }
};

// Groups the cloud's points by (scan, x, y, z) and counts the points that coincide across scans;
// O(n log n), cancellable.
absl::StatusOr<DuplicateGroups> FindDuplicates(const PointCloud& cloud, const CancelToken& cancel);

// The cloud with one point per group (the group's first), every per-point array and the scans.
PointCloud CompactDuplicates(const PointCloud& cloud, const DuplicateGroups& groups);

// Writes each group's result (position, normal, flags) back to every input point of the group.
void ExpandDuplicates(const PointCloud& compact, const DuplicateGroups& groups, PointCloud& cloud);

}  // namespace scanprep

// SPDX-License-Identifier: Apache-2.0
// Duplicates: points of one scan closer than the sensor can tell apart — identical coordinates
// (scanners that repeat a point for a missing sample, clients that send a scan's points twice)
// or a cluster of near-identical ones (a sensor's zero-range returns: thousands within a few
// float steps). Points of one scan in one cube of edge ε = u/100 (u the finest stated
// uncertainty, at most an eighth of any stated spacing) are one measurement.
// Every stage sees each such group once, through its first point; the others are given that
// point's result on the way out (a member elsewhere in the cube moved as its first point moved).
// A pile of them would otherwise fill every ball around it with thousands of points and hide a
// duplicated spike from the outlier rule (d₁ = 0): with at most one point per cube and scan, no
// input is denser than the job's sensors resolve.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/cancel.h"
#include "core/base/point_cloud.h"

namespace scanprep {

struct DuplicateGroups {
  // Per input point: its group's index in the compacted cloud (groups in input order).
  std::vector<uint32_t> group_of;
  // Per group: how many input points it stands for.
  std::vector<uint32_t> multiplicity;
  // Per scan: its input points within the resolution cube's edge ε of a group's first point of a
  // lower-numbered scan (near_repeats.h: a scan sent twice, a re-exported copy, a registration
  // that copied points; exact positions when ε is 0). Not collapsed, since each scan keeps its own
  // points, but counted so that the report can say so.
  std::vector<uint64_t> repeated_per_scan;
  size_t coincident_across_scans = 0;  // their sum

  size_t collapsed() const { return group_of.size() - multiplicity.size(); }
};

// Groups the cloud's points by scan and resolution cube (by exact position when no scan states a
// positive uncertainty) and counts each scan's points within ε of the first point of a group of a
// lower-numbered scan; O(n log n), cancellable.
absl::StatusOr<DuplicateGroups> FindDuplicates(const PointCloud& cloud, const CancelToken& cancel);

// The cloud with one point per group (the group's first), every per-point array and the scans.
PointCloud CompactDuplicates(const PointCloud& cloud, const DuplicateGroups& groups);

// Writes each group's result (normal, flags; the position, or for a member not at its first
// point's input position that position moved as the first point moved) to every input point of
// the group.
void ExpandDuplicates(const PointCloud& compact, const DuplicateGroups& groups, PointCloud& cloud);

}  // namespace scanprep

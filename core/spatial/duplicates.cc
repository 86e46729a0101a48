// SPDX-License-Identifier: Apache-2.0
#include "core/spatial/duplicates.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "core/base/parallel.h"
#include "core/base/status_macros.h"
#include "core/spatial/cell_hash.h"
#include "core/spatial/near_repeats.h"

namespace scanprep {
namespace {

// The cells points of one scan are taken as one measurement in: cubes of edge u/100 for the
// finest stated uncertainty u of the job's scans (a hundredth of what the sensor can tell apart),
// at most an eighth of any stated point or scanline spacing, so that two samples the sensor took
// apart never share one. Measured on the simulated box (21 k points, u = 0.03 mm): u/(4√3)
// joined 281 points of one scan where grazing walls crowd the samples, u/100 none. The default
// u (0.1 mm) counts too when none is stated: cubes of 1 µm part no optical scanner's samples,
// and without them 8,000 returns within 1e-4 mm beside a 50 k-point plane cost 8.6x the plane.
// 0 (exact positions) when no scan has a positive u.
constexpr double kCellPerUncertainty = 0.01;
double ResolutionCell(const PointCloud& cloud) {
  double edge = HUGE_VAL;
  for (const ScanMeta& scan : cloud.scans) {
    if (scan.uncertainty > 0) edge = std::min(edge, kCellPerUncertainty * scan.uncertainty);
    for (const double spacing : {scan.point_spacing, scan.scanline_spacing}) {
      if (spacing > 0) edge = std::min(edge, spacing / 8);
    }
  }
  return std::isfinite(edge) ? edge : 0;
}

// A point's cell of edge `edge` (its exact coordinates when edge is 0), as three integers.
struct Cell {
  int64_t v[3];
  bool operator==(const Cell&) const = default;
};
Cell CellOf(const PointCloud& cloud, uint32_t i, double edge) {
  return {
      {CellNumber(cloud.x[i], edge), CellNumber(cloud.y[i], edge), CellNumber(cloud.z[i], edge)}};
}

// Each group's first input point, in group order.
std::vector<uint32_t> GroupFirsts(const DuplicateGroups& groups) {
  std::vector<uint32_t> firsts;
  firsts.reserve(groups.multiplicity.size());
  for (size_t i = 0; i < groups.group_of.size(); ++i) {
    if (groups.group_of[i] == firsts.size()) firsts.push_back(static_cast<uint32_t>(i));
  }
  return firsts;
}

template <typename T>
void KeepFirsts(const std::vector<T>& from, const std::vector<uint32_t>& firsts,
                std::vector<T>& to) {
  if (from.empty()) return;
  to.resize(firsts.size());
  for (size_t g = 0; g < firsts.size(); ++g) to[g] = from[firsts[g]];
}

}  // namespace

absl::StatusOr<DuplicateGroups> FindDuplicates(const PointCloud& cloud, const CancelToken& cancel) {
  const size_t n = cloud.size();
  // (hash of the resolution cell, scan · 2³² + index) sorted: the points of one cell are
  // adjacent, scan by scan, each scan's lowest index first. Points at one position share a cell.
  const double edge = ResolutionCell(cloud);
  std::vector<std::pair<uint64_t, uint64_t>> keyed(n);
  SCANPREP_RETURN_IF_ERROR(ParallelFor(n, cancel, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const Cell c = CellOf(cloud, static_cast<uint32_t>(i), edge);
      keyed[i] = {HashCell(c.v[0], c.v[1], c.v[2]), (uint64_t(cloud.scan[i]) << 32) | i};
    }
  }));
  SCANPREP_RETURN_IF_ERROR(CancellableSort(keyed, cancel));

  // first[i]: the lowest index of i's group. Within a run of equal hashes each point is compared
  // with the groups of its scan so far (one, unless 64-bit hashes collide).
  std::vector<uint32_t> first(n);
  std::vector<uint32_t> scan_points;
  for (size_t begin = 0, runs = 0; begin < n; ++runs) {
    if ((runs & 0xffff) == 0) {
      SCANPREP_RETURN_IF_ERROR(cancel.Check());
    }
    size_t end = begin + 1;
    while (end < n && keyed[end].first == keyed[begin].first) ++end;
    scan_points.clear();
    for (size_t e = begin; e < end; ++e) {
      if (e > begin && keyed[e].second >> 32 != keyed[e - 1].second >> 32) scan_points.clear();
      const uint32_t i = static_cast<uint32_t>(keyed[e].second);
      uint32_t group = i;
      for (const uint32_t d : scan_points) {
        if (CellOf(cloud, d, edge) == CellOf(cloud, i, edge)) group = d;
      }
      if (group == i) scan_points.push_back(i);
      first[i] = group;
    }
    begin = end;
  }
  keyed = {};

  DuplicateGroups groups;
  groups.group_of.resize(n);
  for (size_t i = 0; i < n; ++i) {
    if (first[i] == i) {
      groups.group_of[i] = static_cast<uint32_t>(groups.multiplicity.size());
      groups.multiplicity.push_back(1);
    } else {
      groups.group_of[i] = groups.group_of[first[i]];  // first[i] < i: already numbered
      ++groups.multiplicity[groups.group_of[i]];
    }
  }
  first = {};
  SCANPREP_ASSIGN_OR_RETURN(groups.repeated_per_scan,
                            CountNearRepeats(cloud, GroupFirsts(groups), edge, cancel));
  for (const uint64_t repeated : groups.repeated_per_scan) {
    groups.coincident_across_scans += repeated;
  }
  return groups;
}

PointCloud CompactDuplicates(const PointCloud& cloud, const DuplicateGroups& groups) {
  const std::vector<uint32_t> firsts = GroupFirsts(groups);
  PointCloud compact;
  compact.scans = cloud.scans;
  compact.kind = cloud.kind;
  for (auto member : {&PointCloud::x, &PointCloud::y, &PointCloud::z, &PointCloud::quality,
                      &PointCloud::intensity, &PointCloud::nx, &PointCloud::ny, &PointCloud::nz}) {
    KeepFirsts(cloud.*member, firsts, compact.*member);
  }
  KeepFirsts(cloud.scan, firsts, compact.scan);
  KeepFirsts(cloud.scanline, firsts, compact.scanline);
  KeepFirsts(cloud.flags, firsts, compact.flags);
  return compact;
}

void ExpandDuplicates(const PointCloud& compact, const DuplicateGroups& groups, PointCloud& cloud) {
  const size_t n = cloud.size();
  if (compact.has_normals()) {
    cloud.nx.resize(n), cloud.ny.resize(n), cloud.nz.resize(n);
  }
  // Each group's first point as it came in, before its result overwrites it: a member elsewhere
  // in the cell moves as its group's first did (smoothing's shift), an exact copy lands on it.
  const std::vector<uint32_t> firsts = GroupFirsts(groups);
  std::vector<Eigen::Vector3f> came_in(firsts.size());
  for (size_t g = 0; g < firsts.size(); ++g) came_in[g] = cloud.point(firsts[g]);
  for (size_t i = 0; i < n; ++i) {
    const uint32_t g = groups.group_of[i];
    const Eigen::Vector3f moved = compact.point(g) - came_in[g];
    if (cloud.point(i) != came_in[g]) {
      cloud.x[i] += moved.x(), cloud.y[i] += moved.y(), cloud.z[i] += moved.z();
    } else {
      cloud.x[i] = compact.x[g], cloud.y[i] = compact.y[g], cloud.z[i] = compact.z[g];
    }
    if (compact.has_normals()) {
      cloud.nx[i] = compact.nx[g], cloud.ny[i] = compact.ny[g], cloud.nz[i] = compact.nz[g];
    }
    cloud.flags[i] = compact.flags[g];
  }
}

}  // namespace scanprep

// SPDX-License-Identifier: Apache-2.0
#include "core/spatial/near_repeats.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <numeric>

#include "core/base/parallel.h"
#include "core/base/status_macros.h"
#include "core/spatial/cell_hash.h"

namespace scanprep {
namespace {

// Cells of this many tolerances a side: a ball of radius `tolerance` around a point crosses into
// a neighbour along an axis only within a quarter of the cell of that side's face, so a query
// looks in (1 + 1/4)³ ≈ 2 cells on average instead of 8 (each a cache miss at a million points),
// while a cell stays no wider than a stated point spacing (ε ≤ spacing/8).
constexpr double kCellPerTolerance = 8;

// A point as the table holds it, so a candidate costs one memory read.
struct Entry {
  float x, y, z;
  uint32_t scan;
  uint32_t point;
};

// Points bucketed by the hash of their cell: a counting sort, so O(n) whatever the data. Buckets
// at least as many as points.
struct CellTable {
  double edge = 0;
  uint64_t mask = 0;
  std::vector<uint32_t> begin;  // per bucket, into `entries`; one more at the end
  std::vector<Entry> entries;   // bucket by bucket

  uint64_t Bucket(int64_t a, int64_t b, int64_t c) const { return HashCell(a, b, c) & mask; }
};

CellTable BuildTable(const PointCloud& cloud, const std::vector<uint32_t>& points,
                     double tolerance) {
  CellTable table;
  table.edge = kCellPerTolerance * tolerance;
  table.mask = std::bit_ceil(std::max<size_t>(points.size(), 1)) - 1;
  std::vector<uint32_t> bucket_of(points.size());  // buckets ≤ points < 2³²
  table.begin.assign(table.mask + 2, 0);
  for (size_t k = 0; k < points.size(); ++k) {
    const uint32_t i = points[k];
    bucket_of[k] = static_cast<uint32_t>(table.Bucket(CellNumber(cloud.x[i], table.edge),
                                                      CellNumber(cloud.y[i], table.edge),
                                                      CellNumber(cloud.z[i], table.edge)));
    ++table.begin[bucket_of[k] + 1];
  }
  for (size_t b = 1; b < table.begin.size(); ++b) table.begin[b] += table.begin[b - 1];
  table.entries.resize(points.size());
  std::vector<uint32_t> next(table.begin.begin(), table.begin.end() - 1);
  for (size_t k = 0; k < points.size(); ++k) {
    const uint32_t i = points[k];
    table.entries[next[bucket_of[k]]++] = {cloud.x[i], cloud.y[i], cloud.z[i], cloud.scan[i], i};
  }
  return table;
}

// Calls visit(entry) for the tabled points within `tolerance` of point `i` until it returns true
// (then true). It looks in i's own cell and in each neighbour the ball around i reaches (only its
// own when exact), reading at most kNearRepeatCandidates entries of each.
template <typename Visit>
bool VisitNear(const PointCloud& cloud, const CellTable& table, double tolerance, uint32_t i,
               Visit&& visit) {
  const float p[3] = {cloud.x[i], cloud.y[i], cloud.z[i]};
  int64_t cell[3], low[3], high[3];
  for (int a = 0; a < 3; ++a) {
    cell[a] = CellNumber(p[a], table.edge);
    const double within = table.edge > 0 ? double(p[a]) - double(cell[a]) * table.edge : 0;
    low[a] = table.edge > 0 && within < tolerance ? -1 : 0;
    high[a] = table.edge > 0 && table.edge - within < tolerance ? 1 : 0;
  }
  const double limit = tolerance * tolerance;
  for (int64_t da = low[0]; da <= high[0]; ++da) {
    for (int64_t db = low[1]; db <= high[1]; ++db) {
      for (int64_t dc = low[2]; dc <= high[2]; ++dc) {
        const uint64_t b = table.Bucket(cell[0] + da, cell[1] + db, cell[2] + dc);
        const uint32_t end =
            std::min<uint32_t>(table.begin[b + 1], table.begin[b] + kNearRepeatCandidates);
        for (uint32_t e = table.begin[b]; e < end; ++e) {
          const Entry& q = table.entries[e];
          const double dx = double(p[0]) - q.x, dy = double(p[1]) - q.y, dz = double(p[2]) - q.z;
          if (dx * dx + dy * dy + dz * dz <= limit && visit(q)) return true;
        }
      }
    }
  }
  return false;
}

// Up to kNearRepeatSample of the standing points of each scan but the first, evenly through the
// upload order.
std::vector<uint32_t> SampleLaterScans(const PointCloud& cloud,
                                       const std::vector<uint32_t>& standing) {
  std::vector<size_t> count(cloud.scans.size(), 0), seen(cloud.scans.size(), 0);
  for (const uint32_t i : standing) ++count[cloud.scan[i]];
  std::vector<uint32_t> sample;
  for (const uint32_t i : standing) {
    const uint32_t s = cloud.scan[i];
    const size_t stride = std::max<size_t>(1, count[s] / kNearRepeatSample);
    if (s > 0 && seen[s]++ % stride == 0) sample.push_back(i);
  }
  return sample;
}

// A scan whose own points lie within the tolerance of each other at more than this share of its
// sample is not resolved by it (a unit slip in the metadata: a stated u a thousand times the
// spacing makes ε ten spacings), and points of another scan that close say nothing; such a scan
// is compared by exact position only.
constexpr double kMaxUnresolvedShare = 0.05;

// What the sample found of a scan: a point near an earlier scan's, one at exactly its position.
enum SampleFinding : uint8_t { kNear = 1, kExact = 2 };

// Per scan, the tolerance to count it at: the given one, 0 (exact positions: the scan is not
// resolved at it) or −1 (not counted: no sampled point is near an earlier scan's). The sample is
// tabled (it fits in cache), and every standing point looks in it.
absl::StatusOr<std::vector<double>> ToleranceToCount(const PointCloud& cloud,
                                                     const std::vector<uint32_t>& standing,
                                                     double tolerance, const CancelToken& cancel) {
  const CellTable sample = BuildTable(cloud, SampleLaterScans(cloud, standing), tolerance);
  std::vector<uint8_t> found(cloud.scans.size(), 0);
  std::vector<uint8_t> unresolved(sample.entries.size(), 0);  // per entry: its scan's own nearby
  SCANPREP_RETURN_IF_ERROR(ParallelFor(standing.size(), cancel, [&](size_t begin, size_t end) {
    for (size_t k = begin; k < end; ++k) {
      const uint32_t j = standing[k];
      VisitNear(cloud, sample, tolerance, j, [&](const Entry& q) {
        if (q.scan > cloud.scan[j]) {
          const bool exact = q.x == cloud.x[j] && q.y == cloud.y[j] && q.z == cloud.z[j];
          std::atomic_ref(found[q.scan])
              .fetch_or(exact ? kNear | kExact : kNear, std::memory_order_relaxed);
        } else if (q.scan == cloud.scan[j] && q.point != j) {
          std::atomic_ref(unresolved[&q - sample.entries.data()])
              .store(1, std::memory_order_relaxed);
        }
        return false;
      });
    }
  }));
  std::vector<size_t> sampled(cloud.scans.size(), 0), own(cloud.scans.size(), 0);
  for (size_t e = 0; e < sample.entries.size(); ++e) {
    ++sampled[sample.entries[e].scan];
    own[sample.entries[e].scan] += unresolved[e];
  }
  std::vector<double> at(cloud.scans.size(), -1);
  for (size_t s = 0; s < at.size(); ++s) {
    if (own[s] <= kMaxUnresolvedShare * sampled[s]) {
      if (found[s] & kNear) at[s] = tolerance;
    } else if (found[s] & kExact) {
      at[s] = 0;
    }
  }
  return at;
}

// The points of `points` whose scan comes before the last scan `at` counts at a tolerance that
// `wanted` accepts: those scans' candidates.
template <typename Wanted>
std::vector<uint32_t> CandidatesFor(const PointCloud& cloud, const std::vector<uint32_t>& points,
                                    const std::vector<double>& at, Wanted wanted) {
  uint32_t before = 0;
  for (uint32_t s = 0; s < at.size(); ++s) {
    if (wanted(at[s])) before = s;
  }
  std::vector<uint32_t> candidates;
  for (const uint32_t i : points) {
    if (cloud.scan[i] < before) candidates.push_back(i);
  }
  return candidates;
}

}  // namespace

absl::StatusOr<std::vector<uint64_t>> CountNearRepeats(const PointCloud& cloud,
                                                       const std::vector<uint32_t>& standing,
                                                       double tolerance,
                                                       const CancelToken& cancel) {
  std::vector<uint64_t> per_scan(cloud.scans.size(), 0);
  if (cloud.scans.size() < 2) return per_scan;
  SCANPREP_ASSIGN_OR_RETURN(const std::vector<double> at,
                            ToleranceToCount(cloud, standing, tolerance, cancel));
  // A scan counted at the tolerance looks among the standing points of the scans before it; one
  // counted by exact position (not resolved at it) among all their points, which its cubes do not
  // stand for then.
  const bool any_exact = tolerance > 0 && std::find(at.begin(), at.end(), 0.0) != at.end();
  std::vector<uint32_t> all;
  if (any_exact) {
    all.resize(cloud.size());
    std::iota(all.begin(), all.end(), 0u);
  }
  const CellTable near = BuildTable(
      cloud, CandidatesFor(cloud, standing, at, [&](double t) { return t == tolerance; }),
      tolerance);
  const CellTable exact =
      BuildTable(cloud, CandidatesFor(cloud, all, at, [](double t) { return t == 0; }), 0);
  std::vector<uint8_t> repeats(cloud.size(), 0);
  SCANPREP_RETURN_IF_ERROR(ParallelFor(cloud.size(), cancel, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const uint32_t s = cloud.scan[i];
      if (at[s] < 0) continue;
      const CellTable& table = at[s] == tolerance ? near : exact;
      repeats[i] = VisitNear(cloud, table, at[s], static_cast<uint32_t>(i),
                             [&](const Entry& q) { return q.scan < s; });
    }
  }));
  for (size_t i = 0; i < cloud.size(); ++i) per_scan[cloud.scan[i]] += repeats[i];
  return per_scan;
}

}  // namespace scanprep

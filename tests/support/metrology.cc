// SPDX-License-Identifier: Apache-2.0
#include "tests/support/metrology.h"

#include <algorithm>
#include <atomic>

#include "core/base/parallel.h"
#include "tests/support/kdtree.h"

namespace scanprep::testing {
namespace {

// The simulator's planar faces are all axis-aligned, its curved ones (bore, sphere, cylinder)
// have such normals only on lines of measure zero.
bool OnPlanarFace(const Eigen::Vector3f& normal) {
  return normal.cwiseAbs().maxCoeff() > 1.0f - 1e-6f;
}

struct SumOfSquares {
  double sum = 0;
  size_t n = 0;
  void Add(double d) { sum += d * d, ++n; }
  ZoneError Result() const { return {n > 0 ? std::sqrt(sum / n) : std::nan(""), n}; }
};

double Coverage(const sim::SimulatedCloud& sim, const PointCloud& processed) {
  PointCloud kept;
  for (size_t i = 0; i < processed.size(); ++i) {
    if (processed.removed(i)) continue;
    kept.x.push_back(processed.x[i]);
    kept.y.push_back(processed.y[i]);
    kept.z.push_back(processed.z[i]);
  }
  if (kept.size() == 0) return 0;
  const KdTree tree(kept);
  const float radius_sq = static_cast<float>(std::pow(CoverageRadiusMm(sim), 2));
  std::atomic<size_t> covered{0}, samples{0};
  const CancelToken never;
  (void)ParallelFor(sim.cloud.size(), never, [&](size_t begin, size_t end) {
    size_t c = 0, s = 0;
    for (size_t i = begin; i < end; ++i) {
      if (sim.is_outlier[i]) continue;
      uint32_t index;
      float dist_sq;
      ++s;
      c += tree.Knn(sim.truth[i].data(), 1, &index, &dist_sq) == 1 && dist_sq <= radius_sq;
    }
    covered += c;
    samples += s;
  });
  return samples > 0 ? double(covered) / double(samples) : 0;
}

}  // namespace

double CoverageRadiusMm(const sim::SimulatedCloud& sim) {
  double spacing = 0;
  for (const ScanMeta& scan : sim.cloud.scans) {
    spacing = std::max({spacing, scan.scanline_spacing, scan.point_spacing});
  }
  return 2 * spacing;
}

EdgeFlags EdgeFlagsAgainstTruth(const sim::SimulatedCloud& sim, const PointCloud& processed) {
  EdgeFlags flags;
  for (size_t i = 0; i < processed.size(); ++i) {
    if (sim.is_outlier[i] || (processed.flags[i] & (kRemovedOutlier | kRemovedMerge))) continue;
    const float* band =
        std::upper_bound(std::begin(kEdgeBandsMm), std::end(kEdgeBandsMm), sim.edge_distance[i]);
    const size_t b = static_cast<size_t>(band - std::begin(kEdgeBandsMm));
    const bool edge = (processed.flags[i] & kEdge) != 0;
    const bool curved = sim.edge_distance[i] > kEdgeZoneMm && !OnPlanarFace(sim.true_normal[i]);
    const bool returned = !processed.removed(i);
    for (auto [share, counts] : {std::pair{&flags.measured[b], true},
                                 {&flags.returned[b], returned},
                                 {&flags.curved_measured, curved},
                                 {&flags.curved_returned, curved && returned}}) {
      share->points += counts;
      share->flagged += counts && edge;
    }
  }
  return flags;
}

Metrology MeasureAgainstTruth(sim::Part part, const sim::SimulatedCloud& sim,
                              const PointCloud& processed) {
  SumOfSquares flat, curved, edge, convex, concave;
  size_t removed = 0, removed_spikes = 0, spikes = 0;
  for (size_t i = 0; i < processed.size(); ++i) {
    const bool spike = sim.is_outlier[i] != 0;
    const bool flagged = (processed.flags[i] & kRemovedOutlier) != 0;
    spikes += spike;
    removed += flagged;
    removed_spikes += flagged && spike;
    if (spike || processed.removed(i)) continue;
    const double d = sim::DistanceToSurface(part, processed.point(i).cast<double>());
    const float e = sim.edge_distance[i];
    if (e > kEdgeZoneMm) {
      (OnPlanarFace(sim.true_normal[i]) ? flat : curved).Add(d);
      continue;
    }
    edge.Add(d);
    if (e <= kSharpZoneMm) (sim.edge_convex[i] ? convex : concave).Add(d);
  }
  Metrology m;
  m.flat = flat.Result();
  m.curved = curved.Result();
  m.edge = edge.Result();
  m.convex = convex.Result();
  m.concave = concave.Result();
  if (removed > 0) m.precision = double(removed_spikes) / double(removed);
  m.recall = spikes > 0 ? double(removed_spikes) / double(spikes) : std::nan("");
  m.coverage = Coverage(sim, processed);
  m.points_out = processed.CountKept();
  return m;
}

}  // namespace scanprep::testing

// SPDX-License-Identifier: Apache-2.0
// Ground-truth metrology of a processed simulated cloud: how far the surviving points lie from
// the true surface, zone by zone, how well the injected spikes were removed, and how much of the
// surface is still represented. The same numbers for the unprocessed cloud are the "raw" row.
//
// Zones, by where each sample's true point lies (SimulatedCloud::truth, edge_distance):
// - flat:    planar face, more than kEdgeZoneMm from every sharp edge;
// - curved:  curved face (the bore wall, sphere, cylinder), more than kEdgeZoneMm from an edge;
// - edge:    within kEdgeZoneMm of a sharp edge (either kind): where smoothing rounds edges off;
// - convex / concave: within kSharpZoneMm of a convex / concave edge (the nearest edge's kind):
//   the few point spacings where an edge is rounded or sharpened.
// Each zone's RMS is over the points that survived (not flagged removed by any stage) and are not
// injected spikes: the spikes are scored by precision and recall instead.
#pragma once

#include <cmath>
#include <cstddef>
#include <iterator>

#include "core/base/point_cloud.h"
#include "core/sim/scan_simulator.h"

namespace scanprep::testing {

inline constexpr float kEdgeZoneMm = 1.0f;
inline constexpr float kSharpZoneMm = 0.2f;

struct ZoneError {
  double rms = std::nan("");  // NaN when the zone holds no point
  size_t points = 0;
};

struct Metrology {
  ZoneError flat, curved, edge, convex, concave;
  // Points flagged kRemovedOutlier against the injected spikes: precision = share of the
  // removed that are spikes (NaN when none was removed), recall = share of spikes removed.
  double precision = std::nan("");
  double recall = std::nan("");
  // Share of the non-spike samples whose true point has a surviving point within
  // CoverageRadiusMm: 1 unless a stage left holes in the surface.
  double coverage = 0;
  size_t points_out = 0;
};

// Twice the largest nominal scanline spacing of the scans: a hole counts only when it is wider
// than two scanlines, which no thinning to the simplification's spacing 2·√(Δs·Δp) may leave.
double CoverageRadiusMm(const sim::SimulatedCloud& sim);

// The EDGE flag against each sample's true distance to the nearest sharp edge, in bands with
// these upper bounds (mm); the last band is everything farther (flat faces, curved ones, parts
// without an edge). Spikes are left out.
inline constexpr float kEdgeBandsMm[] = {0.1f, 0.3f, 1.0f, 3.0f};
inline constexpr size_t kEdgeBands = std::size(kEdgeBandsMm) + 1;

struct FlaggedShare {
  size_t points = 0, flagged = 0;
  double share() const { return points > 0 ? double(flagged) / double(points) : std::nan(""); }
};
struct EdgeFlags {
  // measured: the points the measures stage judged and smoothing saw (those simplification
  // thinned included); returned: the points the job returns.
  FlaggedShare measured[kEdgeBands], returned[kEdgeBands];
  // The curved zone (curved faces more than kEdgeZoneMm from a sharp edge), likewise: a bore or
  // a fillet is curvature, not an edge.
  FlaggedShare curved_measured, curved_returned;
};
EdgeFlags EdgeFlagsAgainstTruth(const sim::SimulatedCloud& sim, const PointCloud& processed);

// `processed` is `sim.cloud` after a pipeline run: the same points in the same order, removed
// points still present and flagged. Pass sim.cloud itself for the raw row.
Metrology MeasureAgainstTruth(sim::Part part, const sim::SimulatedCloud& sim,
                              const PointCloud& processed);

}  // namespace scanprep::testing

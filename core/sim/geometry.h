// Small exact queries on axis-aligned boxes, rectangles and segments shared by the simulator's
// parts (box with bore, stepped block).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

namespace scanprep::sim {

// Where the line o + t·d runs inside the box [lo, hi] (bounds may be infinite, for slabs and
// half-spaces), with the box's outward normals at the entry and exit faces. None when the line
// misses the box. The interval may start behind o.
struct BoxInterval {
  double enter, exit;
  Eigen::Vector3d enter_normal, exit_normal;
};

inline std::optional<BoxInterval> LineThroughBox(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                                                 const Eigen::Vector3d& lo,
                                                 const Eigen::Vector3d& hi) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  BoxInterval b{-kInf, kInf, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-15) {
      if (o[a] < lo[a] || o[a] > hi[a]) return std::nullopt;
      continue;
    }
    double t1 = (lo[a] - o[a]) / d[a], t2 = (hi[a] - o[a]) / d[a];
    if (t1 > t2) std::swap(t1, t2);
    if (t1 > b.enter) {
      b.enter = t1;
      b.enter_normal = Eigen::Vector3d::Zero();
      b.enter_normal[a] = d[a] > 0 ? -1 : 1;
    }
    if (t2 < b.exit) {
      b.exit = t2;
      b.exit_normal = Eigen::Vector3d::Zero();
      b.exit_normal[a] = d[a] > 0 ? 1 : -1;
    }
  }
  if (b.enter > b.exit) return std::nullopt;
  return b;
}

// Closest point to p of the axis-aligned rectangle (or box) [lo, hi].
inline Eigen::Vector3d ClosestInBox(const Eigen::Vector3d& p, const Eigen::Vector3d& lo,
                                    const Eigen::Vector3d& hi) {
  return p.cwiseMax(lo).cwiseMin(hi);
}

inline double DistanceToSegment(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (p - (a + t * ab)).norm();
}

// Distances from a point to the nearest convex and to the nearest concave sharp edge
// (infinity where the part has none of that kind).
struct EdgeDistances {
  double convex = std::numeric_limits<double>::infinity();
  double concave = std::numeric_limits<double>::infinity();
};

}  // namespace scanprep::sim

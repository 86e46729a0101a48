// SPDX-License-Identifier: Apache-2.0
// Small exact queries on axis-aligned boxes, rectangles and segments shared by the simulator's
// parts (box with bore, stepped block).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>

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

// Roots of a t² + b t + c = 0 in ascending order, if real and distinct.
inline std::optional<std::pair<double, double>> Quadratic(double a, double b, double c) {
  const double disc = b * b - 4 * a * c;
  if (a <= 0 || disc <= 0) return std::nullopt;
  const double s = std::sqrt(disc);
  return std::pair{(-b - s) / (2 * a), (-b + s) / (2 * a)};
}

// A cylindrical hole along z through a block (the box's and the stepped block's bores).
struct VerticalBore {
  Eigen::Vector2d centre;
  double radius;

  // Where the line o + t·d runs inside the infinite cylinder: (in, out); (inf, -inf) if nowhere.
  std::pair<double, double> Interval(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    const Eigen::Vector2d q = o.head<2>() - centre;
    const double a = d.head<2>().squaredNorm(), c = q.squaredNorm() - radius * radius;
    if (a < 1e-18) return c < 0 ? std::pair{-kInf, kInf} : std::pair{kInf, -kInf};
    if (auto roots = Quadratic(a, 2 * q.dot(d.head<2>()), c)) return *roots;
    return {kInf, -kInf};
  }

  // Unit horizontal direction from the axis toward p (any, on the axis).
  Eigen::Vector3d Radial(const Eigen::Vector3d& p) const {
    const Eigen::Vector2d q = p.head<2>() - centre;
    const double rho = q.norm();
    return rho > 0 ? Eigen::Vector3d(q.x() / rho, q.y() / rho, 0) : Eigen::Vector3d::UnitX();
  }

  // The wall point closest to p between heights 0 and `height`; the solid's outward normal
  // there is -Radial(p).
  Eigen::Vector3d ClosestOnWall(const Eigen::Vector3d& p, double height) const {
    return Eigen::Vector3d(centre.x(), centre.y(), std::clamp(p.z(), 0.0, height)) +
           radius * Radial(p);
  }

  // Closest point to p of the horizontal rectangle [lo, hi] (lo.z() == hi.z()) minus the bore's
  // disc, which must lie inside the rectangle.
  Eigen::Vector3d ClosestOnCap(const Eigen::Vector3d& p, const Eigen::Vector3d& lo,
                               const Eigen::Vector3d& hi) const {
    Eigen::Vector3d c = p.cwiseMax(lo).cwiseMin(hi);
    if ((c.head<2>() - centre).norm() < radius) c.head<2>() = centre + radius * Radial(c).head<2>();
    return c;
  }

  // Distance from p to the bore's rim at height z.
  double RimDistance(const Eigen::Vector3d& p, double z) const {
    return std::hypot((p.head<2>() - centre).norm() - radius, p.z() - z);
  }
};

// Distances from a point to the nearest convex and to the nearest concave sharp edge
// (infinity where the part has none of that kind).
struct EdgeDistances {
  double convex = std::numeric_limits<double>::infinity();
  double concave = std::numeric_limits<double>::infinity();
};

}  // namespace scanprep::sim

// SPDX-License-Identifier: Apache-2.0
// The stepped block: a box with a slot milled along y through its top, so it has concave 90°
// edges (where the slot's walls meet its floor) besides convex ones (the box's edges, the slot's
// rims and its outline on the end faces, the rims of a bore beside the slot, whose wall is the
// part's one curved face). Exact ray intersection, closest point and edge distances; the
// dimensions are in PartGeometry.
#pragma once

#include <Eigen/Core>
#include <optional>

#include "core/sim/geometry.h"

namespace scanprep::sim::stepped_block {

struct SurfacePoint {
  Eigen::Vector3d point;
  Eigen::Vector3d normal;  // outward
};

// First point where the ray o + t·d (t > eps) enters the solid, with its outward normal.
struct RayHit {
  double t;
  Eigen::Vector3d normal;
};
std::optional<RayHit> Intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d);

// The surface point closest to p.
SurfacePoint Closest(const Eigen::Vector3d& p);

EdgeDistances Edges(const Eigen::Vector3d& p);

}  // namespace scanprep::sim::stepped_block

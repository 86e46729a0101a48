// SPDX-License-Identifier: Apache-2.0
#include "core/sim/stepped_block.h"

#include <algorithm>
#include <array>
#include <limits>
#include <utility>

#include "core/sim/scan_simulator.h"

namespace scanprep::sim::stepped_block {
namespace {

using Eigen::Vector3d;
using G = PartGeometry;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps = 1e-9;
// Half extents, top, the slot's half width and its floor's height.
constexpr double kHx = G::box_half_x, kHy = G::box_half_y, kTop = G::box_height;
constexpr double kW = G::slot_half_width, kFloor = G::box_height - G::slot_depth;
const VerticalBore kBore{{G::stepped_bore_x, 0}, G::stepped_bore_radius};

struct Face {
  Vector3d lo, hi, normal;  // an axis-aligned rectangle (lo and hi agree on one axis)
};

// The surface except the bore's wall and the two faces it pierces (see Closest): axis-aligned
// rectangles.
const std::array<Face, 12>& Faces() {
  static const std::array<Face, 12> faces = [] {
    std::array<Face, 12> r = {{
        {{-kHx, -kHy, kTop}, {-kW, kHy, kTop}, Vector3d::UnitZ()},    // top, left of the slot
        {{-kW, -kHy, kFloor}, {kW, kHy, kFloor}, Vector3d::UnitZ()},  // slot floor
        {{-kW, -kHy, kFloor}, {-kW, kHy, kTop}, Vector3d::UnitX()},   // slot wall facing +x
        {{kW, -kHy, kFloor}, {kW, kHy, kTop}, -Vector3d::UnitX()},    // slot wall facing -x
        {{kHx, -kHy, 0}, {kHx, kHy, kTop}, Vector3d::UnitX()},
        {{-kHx, -kHy, 0}, {-kHx, kHy, kTop}, -Vector3d::UnitX()},
    }};
    // Each end face is the x-z rectangle minus the slot's notch: three rectangles.
    size_t next = 6;
    for (double y : {kHy, -kHy}) {
      const Vector3d n(0, y > 0 ? 1 : -1, 0);
      r[next++] = {{-kHx, y, 0}, {-kW, y, kTop}, n};
      r[next++] = {{kW, y, 0}, {kHx, y, kTop}, n};
      r[next++] = {{-kW, y, 0}, {kW, y, kFloor}, n};
    }
    return r;
  }();
  return faces;
}

using Segment = std::pair<Vector3d, Vector3d>;

const std::vector<Segment>& ConvexEdges() {
  static const std::vector<Segment> edges = [] {
    std::vector<Segment> e;
    for (double sx : {-1.0, 1.0}) {
      e.push_back({{sx * kHx, -kHy, 0}, {sx * kHx, kHy, 0}});        // bottom, along y
      e.push_back({{sx * kHx, -kHy, kTop}, {sx * kHx, kHy, kTop}});  // top, along y
      e.push_back({{sx * kW, -kHy, kTop}, {sx * kW, kHy, kTop}});    // slot rims
      for (double sy : {-1.0, 1.0}) {
        e.push_back({{sx * kHx, sy * kHy, 0}, {sx * kHx, sy * kHy, kTop}});  // vertical box corners
        e.push_back(
            {{sx * kW, sy * kHy, kFloor}, {sx * kW, sy * kHy, kTop}});  // slot walls' end edges
        e.push_back({{sx * kW, sy * kHy, kTop}, {sx * kHx, sy * kHy, kTop}});  // top, along x
      }
    }
    for (double sy : {-1.0, 1.0}) {
      e.push_back({{-kHx, sy * kHy, 0}, {kHx, sy * kHy, 0}});          // bottom, along x
      e.push_back({{-kW, sy * kHy, kFloor}, {kW, sy * kHy, kFloor}});  // slot floor's end edges
    }
    return e;
  }();
  return edges;
}

const std::array<Segment, 2> kConcaveEdges = {
    {{{-kW, -kHy, kFloor}, {-kW, kHy, kFloor}}, {{kW, -kHy, kFloor}, {kW, kHy, kFloor}}}};

double NearestSegment(const Vector3d& p, const auto& segments) {
  double best = kInf;
  for (const auto& [a, b] : segments) best = std::min(best, DistanceToSegment(p, a, b));
  return best;
}

}  // namespace

// The solid is the box minus the slot prism S = {|x| < kW, z > kFloor} and minus the bore, two
// disjoint convex sets: a ray enters it where it enters the box outside both, or where it leaves
// the one it entered the box in, while still inside the box.
std::optional<RayHit> Intersect(const Vector3d& o, const Vector3d& d) {
  const auto box = LineThroughBox(o, d, {-kHx, -kHy, 0}, {kHx, kHy, kTop});
  if (!box || box->enter <= kEps) return std::nullopt;
  std::optional<RayHit> hit;
  const auto slot = LineThroughBox(o, d, {-kW, -kInf, kFloor}, {kW, kInf, kInf});
  const auto [bore_in, bore_out] = kBore.Interval(o, d);
  if (slot && box->enter > slot->enter && box->enter < slot->exit) {
    hit = RayHit{slot->exit, -slot->exit_normal};
  } else if (box->enter > bore_in && box->enter < bore_out) {
    hit = RayHit{bore_out, -kBore.Radial(o + bore_out * d)};
  } else {
    return RayHit{box->enter, box->enter_normal};
  }
  if (hit->t < box->exit) return hit;
  return std::nullopt;
}

SurfacePoint Closest(const Vector3d& p) {
  SurfacePoint best{p, Vector3d::UnitZ()};
  double best_sq = kInf;
  auto consider = [&](const Vector3d& c, const Vector3d& normal) {
    if (const double sq = (c - p).squaredNorm(); sq < best_sq) {
      best_sq = sq;
      best = {c, normal};
    }
  };
  for (const Face& face : Faces()) consider(ClosestInBox(p, face.lo, face.hi), face.normal);
  // The faces the bore pierces: the top right of the slot and the bottom.
  consider(kBore.ClosestOnCap(p, {kW, -kHy, kTop}, {kHx, kHy, kTop}), Vector3d::UnitZ());
  consider(kBore.ClosestOnCap(p, {-kHx, -kHy, 0}, {kHx, kHy, 0}), -Vector3d::UnitZ());
  consider(kBore.ClosestOnWall(p, kTop), -kBore.Radial(p));
  return best;
}

EdgeDistances Edges(const Vector3d& p) {
  const double rims = std::min(kBore.RimDistance(p, 0), kBore.RimDistance(p, kTop));
  return {std::min(NearestSegment(p, ConvexEdges()), rims), NearestSegment(p, kConcaveEdges)};
}

}  // namespace scanprep::sim::stepped_block

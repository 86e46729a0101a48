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
constexpr double hx = G::box_half_x, hy = G::box_half_y, h = G::box_height;
constexpr double w = G::slot_half_width, f = G::box_height - G::slot_depth;  // slot floor

struct Face {
  Vector3d lo, hi, normal;  // an axis-aligned rectangle (lo and hi agree on one axis)
};

// The surface as axis-aligned rectangles: their union is exactly the boundary of the solid.
const std::array<Face, 14>& Faces() {
  static const std::array<Face, 14> faces = [] {
    std::array<Face, 14> r = {{
        {{-hx, -hy, h}, {-w, hy, h}, Vector3d::UnitZ()},   // top, left of the slot
        {{w, -hy, h}, {hx, hy, h}, Vector3d::UnitZ()},     // top, right of the slot
        {{-w, -hy, f}, {w, hy, f}, Vector3d::UnitZ()},     // slot floor
        {{-w, -hy, f}, {-w, hy, h}, Vector3d::UnitX()},    // slot wall facing +x
        {{w, -hy, f}, {w, hy, h}, -Vector3d::UnitX()},     // slot wall facing -x
        {{-hx, -hy, 0}, {hx, hy, 0}, -Vector3d::UnitZ()},  // bottom
        {{hx, -hy, 0}, {hx, hy, h}, Vector3d::UnitX()},
        {{-hx, -hy, 0}, {-hx, hy, h}, -Vector3d::UnitX()},
    }};
    // Each end face is the x-z rectangle minus the slot's notch: three rectangles.
    size_t next = 8;
    for (double y : {hy, -hy}) {
      const Vector3d n(0, y > 0 ? 1 : -1, 0);
      r[next++] = {{-hx, y, 0}, {-w, y, h}, n};
      r[next++] = {{w, y, 0}, {hx, y, h}, n};
      r[next++] = {{-w, y, 0}, {w, y, f}, n};
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
      e.push_back({{sx * hx, -hy, 0}, {sx * hx, hy, 0}});  // bottom, along y
      e.push_back({{sx * hx, -hy, h}, {sx * hx, hy, h}});  // top, along y
      e.push_back({{sx * w, -hy, h}, {sx * w, hy, h}});    // slot rims
      for (double sy : {-1.0, 1.0}) {
        e.push_back({{sx * hx, sy * hy, 0}, {sx * hx, sy * hy, h}});  // vertical box corners
        e.push_back({{sx * w, sy * hy, f}, {sx * w, sy * hy, h}});    // slot walls' end edges
        e.push_back({{sx * w, sy * hy, h}, {sx * hx, sy * hy, h}});   // top, along x
      }
    }
    for (double sy : {-1.0, 1.0}) {
      e.push_back({{-hx, sy * hy, 0}, {hx, sy * hy, 0}});  // bottom, along x
      e.push_back({{-w, sy * hy, f}, {w, sy * hy, f}});    // slot floor's end edges
    }
    return e;
  }();
  return edges;
}

const std::array<Segment, 2> kConcaveEdges = {{{{-w, -hy, f}, {-w, hy, f}}, {{w, -hy, f}, {w, hy, f}}}};

double NearestSegment(const Vector3d& p, auto const& segments) {
  double best = kInf;
  for (const auto& [a, b] : segments) best = std::min(best, DistanceToSegment(p, a, b));
  return best;
}

}  // namespace

// The solid is the box minus the slot prism S = {|x| < w, z > f}: a ray enters it where it enters
// the box outside S, or where it leaves S while still inside the box.
std::optional<RayHit> Intersect(const Vector3d& o, const Vector3d& d) {
  const auto box = LineThroughBox(o, d, {-hx, -hy, 0}, {hx, hy, h});
  if (!box || box->enter <= kEps) return std::nullopt;
  const auto slot = LineThroughBox(o, d, {-w, -kInf, f}, {w, kInf, kInf});
  if (!slot || !(box->enter > slot->enter && box->enter < slot->exit)) {
    return RayHit{box->enter, box->enter_normal};
  }
  if (slot->exit < box->exit) return RayHit{slot->exit, -slot->exit_normal};
  return std::nullopt;
}

SurfacePoint Closest(const Vector3d& p) {
  SurfacePoint best{p, Vector3d::UnitZ()};
  double best_sq = kInf;
  for (const Face& face : Faces()) {
    const Vector3d c = ClosestInBox(p, face.lo, face.hi);
    if (const double sq = (c - p).squaredNorm(); sq < best_sq) {
      best_sq = sq;
      best = {c, face.normal};
    }
  }
  return best;
}

EdgeDistances Edges(const Vector3d& p) {
  return {NearestSegment(p, ConvexEdges()), NearestSegment(p, kConcaveEdges)};
}

}  // namespace scanprep::sim::stepped_block

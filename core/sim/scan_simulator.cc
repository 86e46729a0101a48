// SPDX-License-Identifier: Apache-2.0
#include "core/sim/scan_simulator.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <random>

#include "core/sim/geometry.h"
#include "core/sim/stepped_block.h"

namespace scanprep::sim {
namespace {

using Eigen::Vector3d;
using G = PartGeometry;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps = 1e-9;
constexpr double kMaxAngle = 80.0 * std::numbers::pi / 180.0;

struct Hit {
  double t;
  Vector3d normal;
};

bool IsBlock(Part part) { return part == Part::kBoxWithBore || part == Part::kSteppedBlock; }

Vector3d PartCentre(Part part) {
  return IsBlock(part) ? Vector3d(0, 0, G::box_height / 2) : Vector3d::Zero();
}

double BoundingRadius(Part part) {
  switch (part) {
    case Part::kPlane:
      return G::plane_half * std::sqrt(2.0);
    case Part::kSphere:
      return G::sphere_radius;
    case Part::kCylinder:
      return std::hypot(G::cylinder_radius, G::cylinder_half_length);
    case Part::kBoxWithBore:
    case Part::kSteppedBlock:
      return Vector3d(G::box_half_x, G::box_half_y, G::box_height / 2).norm();
  }
  return 0;
}

const VerticalBore kBore{Eigen::Vector2d::Zero(), G::bore_radius};

std::optional<Hit> IntersectPlane(const Vector3d& o, const Vector3d& d) {
  if (std::abs(d.z()) < 1e-15) return std::nullopt;
  const double t = -o.z() / d.z();
  const Vector3d p = o + t * d;
  if (t <= kEps || std::abs(p.x()) > G::plane_half || std::abs(p.y()) > G::plane_half) {
    return std::nullopt;
  }
  return Hit{t, Vector3d::UnitZ()};
}

std::optional<Hit> IntersectSphere(const Vector3d& o, const Vector3d& d) {
  const double r = G::sphere_radius;
  auto roots = Quadratic(d.squaredNorm(), 2 * o.dot(d), o.squaredNorm() - r * r);
  if (!roots) return std::nullopt;
  const double t = roots->first > kEps ? roots->first : roots->second;
  if (t <= kEps) return std::nullopt;
  return Hit{t, (o + t * d) / r};
}

std::optional<Hit> IntersectCylinder(const Vector3d& o, const Vector3d& d) {
  const double r = G::cylinder_radius;
  auto roots = Quadratic(d.x() * d.x() + d.z() * d.z(), 2 * (o.x() * d.x() + o.z() * d.z()),
                         o.x() * o.x() + o.z() * o.z() - r * r);
  if (!roots) return std::nullopt;
  for (double t : {roots->first, roots->second}) {
    const Vector3d p = o + t * d;
    if (t > kEps && std::abs(p.y()) <= G::cylinder_half_length) {
      return Hit{t, Vector3d(p.x(), 0, p.z()) / r};
    }
  }
  return std::nullopt;
}

// The solid is the box minus the infinite bore cylinder: the ray enters it where it enters the
// box outside the bore, or where it leaves the bore while still inside the box.
std::optional<Hit> IntersectBoxWithBore(const Vector3d& o, const Vector3d& d) {
  const auto box = LineThroughBox(o, d, {-G::box_half_x, -G::box_half_y, 0},
                                  {G::box_half_x, G::box_half_y, G::box_height});
  if (!box || box->enter <= kEps) return std::nullopt;
  const double enter = box->enter, exit = box->exit;

  const auto [bore_in, bore_out] = kBore.Interval(o, d);
  if (!(enter > bore_in && enter < bore_out)) return Hit{enter, box->enter_normal};
  if (bore_out < exit) return Hit{bore_out, -kBore.Radial(o + bore_out * d)};
  return std::nullopt;
}

std::optional<Hit> Intersect(Part part, const Vector3d& o, const Vector3d& d) {
  switch (part) {
    case Part::kPlane:
      return IntersectPlane(o, d);
    case Part::kSphere:
      return IntersectSphere(o, d);
    case Part::kCylinder:
      return IntersectCylinder(o, d);
    case Part::kBoxWithBore:
      return IntersectBoxWithBore(o, d);
    case Part::kSteppedBlock:
      if (auto hit = stepped_block::Intersect(o, d)) return Hit{hit->t, hit->normal};
      return std::nullopt;
  }
  return std::nullopt;
}

struct Closest {
  Vector3d point, normal;
};

Closest ClosestOnBox(const Vector3d& p) {
  const double hx = G::box_half_x, hy = G::box_half_y, h = G::box_height;
  const double cx = std::clamp(p.x(), -hx, hx), cy = std::clamp(p.y(), -hy, hy),
               cz = std::clamp(p.z(), 0.0, h);
  const std::array<Closest, 7> candidates = {{
      {kBore.ClosestOnCap(p, {-hx, -hy, h}, {hx, hy, h}), Vector3d::UnitZ()},
      {kBore.ClosestOnCap(p, {-hx, -hy, 0}, {hx, hy, 0}), -Vector3d::UnitZ()},
      {{hx, cy, cz}, Vector3d::UnitX()},
      {{-hx, cy, cz}, -Vector3d::UnitX()},
      {{cx, hy, cz}, Vector3d::UnitY()},
      {{cx, -hy, cz}, -Vector3d::UnitY()},
      {kBore.ClosestOnWall(p, h), -kBore.Radial(p)},
  }};
  return *std::min_element(candidates.begin(), candidates.end(),
                           [&](const Closest& a, const Closest& b) {
                             return (a.point - p).squaredNorm() < (b.point - p).squaredNorm();
                           });
}

Closest ClosestOnSurface(Part part, const Vector3d& p) {
  switch (part) {
    case Part::kPlane:
      return {{std::clamp(p.x(), -G::plane_half, G::plane_half),
               std::clamp(p.y(), -G::plane_half, G::plane_half), 0},
              Vector3d::UnitZ()};
    case Part::kSphere: {
      const Vector3d n = p.norm() > 0 ? Vector3d(p.normalized()) : Vector3d::UnitZ();
      return {G::sphere_radius * n, n};
    }
    case Part::kCylinder: {
      const double rho = std::hypot(p.x(), p.z());
      const Vector3d n = rho > 0 ? Vector3d(p.x() / rho, 0, p.z() / rho) : Vector3d::UnitZ();
      const double y = std::clamp(p.y(), -G::cylinder_half_length, G::cylinder_half_length);
      return {G::cylinder_radius * n + Vector3d(0, y, 0), n};
    }
    case Part::kBoxWithBore:
      return ClosestOnBox(p);
    case Part::kSteppedBlock: {
      const auto c = stepped_block::Closest(p);
      return {c.point, c.normal};
    }
  }
  return {p, Vector3d::UnitZ()};
}

// Distance to the nearest sharp edge of the box with bore, all convex: the 12 box edges and the
// two rims of the bore.
double BoxWithBoreEdgeDistance(const Vector3d& p) {
  const double hx = G::box_half_x, hy = G::box_half_y, h = G::box_height;
  double best = kInf;
  auto corner = [&](int i) { return Vector3d(i & 1 ? hx : -hx, i & 2 ? hy : -hy, i & 4 ? h : 0); };
  for (int i = 0; i < 8; ++i) {
    for (int bit : {1, 2, 4}) {
      if (!(i & bit)) best = std::min(best, DistanceToSegment(p, corner(i), corner(i | bit)));
    }
  }
  for (double z : {0.0, h}) best = std::min(best, kBore.RimDistance(p, z));
  return best;
}

EdgeDistances Edges(Part part, const Vector3d& p) {
  switch (part) {
    case Part::kBoxWithBore:
      return {BoxWithBoreEdgeDistance(p), kInf};
    case Part::kSteppedBlock:
      return stepped_block::Edges(p);
    case Part::kPlane:
    case Part::kSphere:
    case Part::kCylinder:
      return {};
  }
  return {};
}

// Line direction u and sweep direction w of a laser sheet travelling along -d.
std::pair<Vector3d, Vector3d> SheetFrame(const Vector3d& d) {
  Vector3d u = Vector3d::UnitY().cross(d);
  if (u.norm() < 1e-6) u = d.cross(Vector3d::UnitX());
  u.normalize();
  return {u, d.cross(u)};
}

double AngleTo(const Vector3d& n, const Vector3d& dir) {
  return std::acos(std::clamp(n.dot(dir.normalized()), -1.0, 1.0));
}

// A sensor whose laser sheet comes from direction d_l and whose camera is tilted from it by
// `camera_tilt_deg` toward the sweep direction, both 200 mm from the part centre.
SimSensor MakeSensor(Part part, const Vector3d& d_l, double camera_tilt_deg, std::string id) {
  const Vector3d c = PartCentre(part);
  const Vector3d w = SheetFrame(d_l.normalized()).second;
  const double tilt = camera_tilt_deg * std::numbers::pi / 180;
  SimSensor s;
  s.laser_position = c + 200.0 * d_l.normalized();
  s.camera_position = c + 200.0 * (std::cos(tilt) * d_l.normalized() + std::sin(tilt) * w);
  s.id = std::move(id);
  return s;
}

Vector3d FrontalDirection(Part part) {
  return IsBlock(part) ? Vector3d(0.6, 0.5, 1).normalized() : Vector3d::UnitZ();
}

void ScanOne(Part part, const SimSensor& sensor, uint32_t scan_index, std::mt19937_64& rng,
             SimulatedCloud& out) {
  const Vector3d centre = PartCentre(part);
  const Vector3d d_l = (sensor.laser_position - centre).normalized();
  const auto [u, w] = SheetFrame(d_l);
  const double extent = BoundingRadius(part);
  const long lines = static_cast<long>(std::floor(2 * extent / sensor.scanline_spacing)) + 1;
  const long samples = static_cast<long>(std::floor(2 * extent / sensor.point_spacing)) + 1;
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double spike_max = std::max(20.0, sensor.outlier_min_sigma);
  const Vector3d camera = sensor.misregistration * sensor.camera_position;

  for (long line = 0; line < lines; ++line) {
    const double b = -extent + line * sensor.scanline_spacing;
    for (long k = 0; k < samples; ++k) {
      const double a = -extent + k * sensor.point_spacing;
      const Vector3d origin = centre + 3 * extent * d_l + a * u + b * w;
      const auto hit = Intersect(part, origin, -d_l);
      if (!hit) continue;
      const Vector3d p = origin - hit->t * d_l;
      const Vector3d to_camera = sensor.camera_position - p;
      const double alpha = AngleTo(hit->normal, to_camera);
      const double beta = AngleTo(hit->normal, d_l);
      const double q = std::max(alpha, beta);
      if (q >= kMaxAngle) continue;  // back-facing or grazing
      const Vector3d ray = -to_camera.normalized();
      const auto seen = Intersect(part, sensor.camera_position, ray);
      if (!seen || seen->t < to_camera.norm() - 1e-6) continue;  // occluded from the camera

      const double sigma = sensor.noise_sigma / std::cos(q);
      double offset = sigma * gauss(rng);
      const bool spike = unit(rng) < sensor.outlier_fraction;
      if (spike) {
        const double size =
            sensor.outlier_min_sigma + (spike_max - sensor.outlier_min_sigma) * unit(rng);
        offset = (unit(rng) < 0.5 ? -1 : 1) * size * sigma;
      }
      const Vector3d measured = sensor.misregistration * Vector3d(p + offset * ray);
      PointCloud& cloud = out.cloud;
      cloud.x.push_back(static_cast<float>(measured.x()));
      cloud.y.push_back(static_cast<float>(measured.y()));
      cloud.z.push_back(static_cast<float>(measured.z()));
      cloud.scan.push_back(scan_index);
      cloud.scanline.push_back(static_cast<uint32_t>(line));
      out.truth.push_back(p.cast<float>());
      out.true_normal.push_back(hit->normal.cast<float>());
      out.is_outlier.push_back(spike ? 1 : 0);
      const EdgeDistances edges = Edges(part, p);
      out.edge_distance.push_back(static_cast<float>(std::min(edges.convex, edges.concave)));
      out.edge_convex.push_back(edges.convex <= edges.concave ? 1 : 0);
    }
  }
  ScanMeta meta;
  meta.id = sensor.id;
  meta.camera_position = camera;
  meta.projector_direction = sensor.misregistration.linear() * d_l;
  meta.scanline_spacing = sensor.scanline_spacing;
  meta.point_spacing = sensor.point_spacing;
  meta.uncertainty = 3 * sensor.noise_sigma;
  out.cloud.scans.push_back(std::move(meta));
}

}  // namespace

SimulatedCloud Simulate(Part part, const std::vector<SimSensor>& sensors, uint64_t seed) {
  SimulatedCloud out;
  out.cloud.kind = ScannerKind::kLine;
  for (size_t s = 0; s < sensors.size(); ++s) {
    std::mt19937_64 rng(seed * 1000003u + s);
    ScanOne(part, sensors[s], static_cast<uint32_t>(s), rng, out);
  }
  out.cloud.FinishLoading();
  return out;
}

double DistanceToSurface(Part part, const Vector3d& p) {
  return (ClosestOnSurface(part, p).point - p).norm();
}

Vector3d SurfaceNormal(Part part, const Vector3d& p) { return ClosestOnSurface(part, p).normal; }

std::vector<SimSensor> FrontalSensor(Part part) {
  return {MakeSensor(part, FrontalDirection(part), 25, "frontal")};
}

std::vector<SimSensor> TwoOverlappingSensors(Part part) {
  const Vector3d d = FrontalDirection(part);
  const Vector3d w = SheetFrame(d).second;
  const double tilt = 45 * std::numbers::pi / 180;
  SimSensor oblique = MakeSensor(part, std::cos(tilt) * d + std::sin(tilt) * w, -25, "oblique");
  oblique.noise_sigma *= 2;
  oblique.misregistration.translation() = Vector3d(0, 0, 0.02);
  return {MakeSensor(part, d, 25, "frontal"), oblique};
}

std::vector<SimSensor> ThreeOverlappingSensors(Part part) {
  return {MakeSensor(part, Vector3d(0.6, 0.3, 1), 25, "from+x"),
          MakeSensor(part, Vector3d(-0.6, 0.3, 1), 25, "from-x"),
          MakeSensor(part, Vector3d(0, -0.6, 1), 25, "from-y")};
}

std::vector<SimSensor> SurroundingSensors(Part part) {
  std::vector<SimSensor> sensors;
  const char* names[] = {"+x", "-x", "+y", "-y", "+z", "-z"};
  for (int i = 0; i < 6; ++i) {
    Vector3d d = Vector3d::Zero();
    d[i / 2] = i % 2 ? -1 : 1;
    sensors.push_back(MakeSensor(part, d, 25, names[i]));
  }
  return sensors;
}

SimulatedCloud SimulateWithPointCount(Part part, std::vector<SimSensor> sensors, size_t points,
                                      double spike_fraction, uint64_t seed) {
  // The count is inversely proportional to the spacings' product only away from the part's
  // borders, so the scale is corrected a few times.
  double scale = 1;
  SimulatedCloud generated;
  for (int attempt = 0; attempt < 4; ++attempt) {
    std::vector<SimSensor> scaled = sensors;
    for (SimSensor& s : scaled) {
      s.scanline_spacing *= scale;
      s.point_spacing *= scale;
      s.outlier_fraction = spike_fraction;
    }
    generated = Simulate(part, scaled, seed);
    const double ratio = double(generated.cloud.size()) / double(points);
    if (generated.cloud.size() == 0 || std::abs(ratio - 1) <= 0.02) break;
    scale *= std::sqrt(ratio);
  }
  return generated;
}

}  // namespace scanprep::sim

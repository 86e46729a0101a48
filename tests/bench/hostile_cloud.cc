// SPDX-License-Identifier: Apache-2.0
#include "tests/bench/hostile_cloud.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <random>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/sim/scan_simulator.h"
#include "tests/bench/bench_cloud.h"

namespace scanprep::bench {
namespace {

using Maker = PointCloud (*)(size_t points);

// Each case's cloud made once per size, like ReferenceCloud.
const PointCloud& Cached(Maker make, size_t points) {
  static std::map<std::pair<Maker, size_t>, std::unique_ptr<PointCloud>> cache;
  auto& slot = cache[{make, points}];
  if (!slot) slot = std::make_unique<PointCloud>(make(points));
  return *slot;
}

// Appends point i of `from` (every per-point array it has) to `to`, in scan `scan`.
void AppendPoint(const PointCloud& from, size_t i, uint32_t scan, PointCloud& to) {
  to.x.push_back(from.x[i]);
  to.y.push_back(from.y[i]);
  to.z.push_back(from.z[i]);
  to.scan.push_back(scan);
  if (from.has_scanlines()) to.scanline.push_back(from.scanline[i]);
  if (!from.quality.empty()) to.quality.push_back(from.quality[i]);
  if (!from.intensity.empty()) to.intensity.push_back(from.intensity[i]);
  to.flags.push_back(from.flags[i]);
}

// Scan index → the index of its first point.
std::map<uint32_t, size_t> FirstPointOfEachScan(const PointCloud& cloud) {
  std::map<uint32_t, size_t> first;
  for (size_t i = 0; i < cloud.size(); ++i) first.try_emplace(cloud.scan[i], i);
  return first;
}

PointCloud FarPoint(size_t points, float x) {
  PointCloud cloud = ReferenceCloud(points);
  AppendPoint(cloud, 0, cloud.scan[0], cloud);
  cloud.x.back() = x;
  return cloud;
}

PointCloud Coincident(size_t points, size_t every) {
  PointCloud cloud = ReferenceCloud(points);
  const std::map<uint32_t, size_t> first = FirstPointOfEachScan(cloud);
  for (size_t i = 0; i < cloud.size(); i += every) {
    const size_t to = first.at(cloud.scan[i]);
    cloud.x[i] = cloud.x[to];
    cloud.y[i] = cloud.y[to];
    cloud.z[i] = cloud.z[to];
  }
  return cloud;
}

// A glint: every `every`-th point moved to a uniform random spot in a ball of radius u/2 around
// its scan's first point (seeded), so one spot holds that share of the points, spread between the
// duplicate collapse's u/100 and u, where every ball around it is full.
PointCloud DenseSpot(size_t points, size_t every) {
  PointCloud cloud = ReferenceCloud(points);
  const std::map<uint32_t, size_t> first = FirstPointOfEachScan(cloud);
  std::mt19937 random(20261128);
  std::uniform_real_distribution<float> unit(-1.f, 1.f);
  for (size_t i = 1; i < cloud.size(); i += every) {
    const size_t to = first.at(cloud.scan[i]);
    const float half_u = static_cast<float>(cloud.scans[cloud.scan[i]].uncertainty / 2);
    float d[3];
    do {
      for (float& v : d) v = unit(random);
    } while (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] > 1.f);
    cloud.x[i] = cloud.x[to] + half_u * d[0];
    cloud.y[i] = cloud.y[to] + half_u * d[1];
    cloud.z[i] = cloud.z[to] + half_u * d[2];
  }
  return cloud;
}

// Points and every length of the scan metadata times `factor`: the same scanner in another unit.
PointCloud Scaled(size_t points, double factor) {
  PointCloud cloud = ReferenceCloud(points);
  for (auto* axis : {&cloud.x, &cloud.y, &cloud.z}) {
    for (float& v : *axis) v = static_cast<float>(v * factor);
  }
  for (ScanMeta& scan : cloud.scans) {
    for (auto* position : {&scan.camera_position, &scan.projector_position}) {
      if (position->has_value()) **position *= factor;
    }
    scan.scanline_spacing *= factor;
    scan.point_spacing *= factor;
    scan.uncertainty *= factor;
  }
  return cloud;
}

PointCloud MakeFarPoint1e6(size_t points) { return FarPoint(points, 1e6f); }
PointCloud MakeFarPoint1e8(size_t points) { return FarPoint(points, 1e8f); }
PointCloud MakeCoincident10Pct(size_t points) { return Coincident(points, 10); }
PointCloud MakeCoincident50Pct(size_t points) { return Coincident(points, 2); }
PointCloud MakeDenseSpot25Pct(size_t points) { return DenseSpot(points, 4); }
PointCloud MakeDenseSpot50Pct(size_t points) { return DenseSpot(points, 2); }
PointCloud MakeMetreDataAsMm(size_t points) { return Scaled(points, 1e-3); }
PointCloud MakeMmDataAsMetres(size_t points) { return Scaled(points, 1e3); }

PointCloud MakeLine(size_t points) {
  PointCloud cloud = ReferenceCloud(points);
  const double spacing = cloud.scans[0].point_spacing;
  for (size_t i = 0; i < cloud.size(); ++i) {
    cloud.x[i] = static_cast<float>(static_cast<double>(i) * spacing);
    cloud.y[i] = cloud.z[i] = 0;
  }
  return cloud;
}

PointCloud MakePlane(size_t points) {
  const auto part = sim::Part::kPlane;
  return sim::SimulateWithPointCount(part, sim::TwoOverlappingSensors(part), points, 0.01, 1).cloud;
}

PointCloud MakeNoPoseUnorganized(size_t points) {
  const auto one_scan = [](sim::Part part, size_t n) {
    return sim::SimulateWithPointCount(part, sim::FrontalSensor(part), n, 0.01, 1).cloud;
  };
  const PointCloud floor = one_scan(sim::Part::kPlane, points / 2);
  const PointCloud sphere = one_scan(sim::Part::kSphere, 1'000);
  PointCloud scene;
  scene.kind = ScannerKind::kFlexible;
  scene.scans = {ScanMeta{.id = "scene"}};
  const auto add = [&](const PointCloud& part, float scale, float dx, float dy, float dz) {
    for (size_t i = 0; i < part.size(); ++i) {
      scene.x.push_back(scale * part.x[i] + dx);
      scene.y.push_back(scale * part.y[i] + dy);
      scene.z.push_back(part.z[i] + dz);
    }
  };
  add(floor, 20, 0, 0, 0);
  const size_t spheres = std::max<size_t>(1, (points - floor.size()) / sphere.size());
  const auto side = static_cast<size_t>(std::ceil(std::sqrt(static_cast<double>(spheres))));
  const float centre = static_cast<float>(side - 1) / 2;
  for (size_t k = 0; k < spheres; ++k) {
    add(sphere, 1, 40 * (static_cast<float>(k % side) - centre),
        40 * (static_cast<float>(k / side) - centre), 15);
  }
  scene.FinishLoading();
  return scene;
}

// kScans scans in all (the server's default max_scans_per_job): points of the reference cloud's
// first scan, evenly spaced, as scans of one point each with its metadata; `alone`: only those,
// else the whole reference cloud with as many such scans as make kScans.
PointCloud OnePointScans(size_t points, bool alone) {
  constexpr size_t kScans = 1'000;
  const PointCloud& reference = ReferenceCloud(points);
  PointCloud cloud;
  cloud.kind = reference.kind;
  if (!alone) cloud.scans = reference.scans;
  const auto first_scan = std::count(reference.scan.begin(), reference.scan.end(), 0u);
  const size_t step = static_cast<size_t>(first_scan) / kScans;
  size_t first_scan_points = 0;
  for (size_t i = 0; i < reference.size(); ++i) {
    uint32_t scan = reference.scan[i];
    const bool single = scan == 0 && first_scan_points++ % step == 0 && cloud.scans.size() < kScans;
    if (single) {
      ScanMeta meta = reference.scans[0];
      meta.id = absl::StrCat("single_", cloud.scans.size());
      scan = static_cast<uint32_t>(cloud.scans.size());
      cloud.scans.push_back(std::move(meta));
    }
    if (single || !alone) AppendPoint(reference, i, scan, cloud);
  }
  return cloud;
}

PointCloud MakeOnePointScans1000(size_t points) { return OnePointScans(points, true); }
PointCloud MakeOrdinaryIn1000Scans(size_t points) { return OnePointScans(points, false); }

}  // namespace

const PointCloud& FarPoint1e6Cloud(size_t points) { return Cached(MakeFarPoint1e6, points); }
const PointCloud& FarPoint1e8Cloud(size_t points) { return Cached(MakeFarPoint1e8, points); }
const PointCloud& Coincident10PctCloud(size_t points) {
  return Cached(MakeCoincident10Pct, points);
}
const PointCloud& Coincident50PctCloud(size_t points) {
  return Cached(MakeCoincident50Pct, points);
}
const PointCloud& DenseSpot25PctCloud(size_t points) { return Cached(MakeDenseSpot25Pct, points); }
const PointCloud& DenseSpot50PctCloud(size_t points) { return Cached(MakeDenseSpot50Pct, points); }
const PointCloud& LineCloud(size_t points) { return Cached(MakeLine, points); }
const PointCloud& PlaneCloud(size_t points) { return Cached(MakePlane, points); }
const PointCloud& MetreDataAsMmCloud(size_t points) { return Cached(MakeMetreDataAsMm, points); }
const PointCloud& MmDataAsMetresCloud(size_t points) { return Cached(MakeMmDataAsMetres, points); }
const PointCloud& NoPoseUnorganizedCloud(size_t points) {
  return Cached(MakeNoPoseUnorganized, points);
}
const PointCloud& OnePointScans1000Cloud(size_t points) {
  return Cached(MakeOnePointScans1000, points);
}
const PointCloud& OrdinaryIn1000ScansCloud(size_t points) {
  return Cached(MakeOrdinaryIn1000Scans, points);
}

}  // namespace scanprep::bench

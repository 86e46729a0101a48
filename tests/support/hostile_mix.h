// SPDX-License-Identifier: Apache-2.0
// Hostile clouds drawn at random, for the index's work-counter tests: an ordinary surface (a
// gently curved, noisy sheet) with any mix of the shapes that broke uniform grids — a far part
// in a random direction, at 1e3-1e6 mm, holding 0.5-30 % of the points; clusters of
// near-identical points (spread 1e-7-1e-2 mm, log-uniform: some inside the cubes the duplicates
// pass joins, the rest just beyond them); lines at 1e-4 mm spacing. The same classes as
// tools/lib/hostile_cases.py draws for the service benchmark, which sends far parts out to
// 1e9 mm: beyond about 2e5 mm float cannot hold a point to a scanner's uncertainty, and the
// service refuses such a job before any index sees it (docs/api.md), so the index is held to
// its bound where float still resolves the part (at 1e6 mm, 0.06 mm).
#pragma once

#include <cmath>
#include <cstdint>
#include <random>
#include <string>

#include <Eigen/Core>

#include "absl/strings/str_format.h"
#include "core/base/point_cloud.h"

namespace scanprep::testing {

struct HostileMix {
  PointCloud cloud;
  std::string description;  // what was drawn, for the failure message
};

// Classes a draw must include (the rest are drawn); `none`: the ordinary sheet alone, the
// control. `cluster_spread` > 0: every cluster spreads this wide (mm) instead of a drawn width.
struct MustInclude {
  bool far = false, clusters = false, none = false;
  double cluster_spread = 0;
};

inline HostileMix DrawHostileMix(size_t n, uint64_t seed, MustInclude must = {}) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0, 1);
  std::normal_distribution<double> gauss(0, 1);
  HostileMix mix;
  PointCloud& cloud = mix.cloud;
  auto add = [&](double x, double y, double z) {
    cloud.x.push_back(static_cast<float>(x));
    cloud.y.push_back(static_cast<float>(y));
    cloud.z.push_back(static_cast<float>(z));
  };
  const bool far = !must.none && (unit(rng) < 0.6 || must.far);
  const bool clusters = !must.none && (unit(rng) < 0.6 || must.clusters);
  const bool line = !must.none && unit(rng) < 0.4;
  const double far_share = far ? 0.005 + 0.295 * unit(rng) : 0;
  const size_t cluster_count = clusters ? 1 + rng() % 3 : 0;
  // Each cluster 1 k to 50 k points, at most a fifth of the cloud.
  const size_t cluster_points = std::min<size_t>(n / 5, 1000 + rng() % 49'000);
  // The far part's place before any point is drawn, so a seed names the same part at any size.
  Eigen::Vector3d direction(gauss(rng), gauss(rng), gauss(rng));
  direction.normalize();
  const double distance = std::pow(10.0, 3 + 3 * unit(rng));
  const size_t line_points = line ? n / 10 : 0;
  const size_t far_points = static_cast<size_t>(far_share * n);
  const size_t sheet = n - far_points - cluster_count * cluster_points - line_points;
  // The ordinary part: a 100 mm sheet with a bump, 0.01 mm noise, seen from +z by one scanner.
  const size_t side = static_cast<size_t>(std::sqrt(double(sheet))) + 1;
  cloud.scans.push_back(ScanMeta{.id = "sheet",
                                 .view_direction = Eigen::Vector3d::UnitZ(),
                                 .scanline_spacing = 100.0 / double(side),
                                 .uncertainty = 0.01});
  for (size_t s = 0; s < sheet; ++s) {
    const double u = 100.0 * double(s % side) / side, v = 100.0 * double(s / side) / side;
    add(u, v, 5 * std::exp(-((u - 50) * (u - 50) + (v - 50) * (v - 50)) / 400) + 0.01 * gauss(rng));
  }
  if (far) {
    const Eigen::Vector3d centre = Eigen::Vector3d(50, 50, 0) + distance * direction;
    for (size_t f = 0; f < far_points; ++f) {  // a 10 mm sphere's surface
      Eigen::Vector3d d(gauss(rng), gauss(rng), gauss(rng));
      const Eigen::Vector3d p = centre + 10 * d.normalized();
      add(p.x(), p.y(), p.z());
    }
    mix.description +=
        absl::StrFormat("far part %.1f%% at %.3g mm towards (%.2f %.2f %.2f); ", 100 * far_share,
                        distance, direction.x(), direction.y(), direction.z());
  }
  for (size_t c = 0; c < cluster_count; ++c) {
    const double drawn = std::pow(10.0, -7 + 5 * unit(rng));
    const double jitter = must.cluster_spread > 0 ? must.cluster_spread : drawn;
    const double cx = 100 * unit(rng), cy = 100 * unit(rng);
    for (size_t p = 0; p < cluster_points; ++p) {
      add(cx + jitter * unit(rng), cy + jitter * unit(rng), 1 + jitter * unit(rng));
    }
    mix.description += absl::StrFormat("cluster of %d within %.2g mm; ", cluster_points, jitter);
  }
  for (size_t l = 0; l < line_points; ++l) add(10 + 1e-4 * double(l), 20, 3);
  if (line) mix.description += absl::StrFormat("line of %d at 1e-4 mm; ", line_points);
  cloud.FinishLoading();
  return mix;
}

}  // namespace scanprep::testing

// SPDX-License-Identifier: Apache-2.0
// CGAL 5.5 bilateral_smooth_point_set as its manual's example calls it, with normals from
// jet_estimate_normals (the manual's choice for smooth input) on the same k neighbours.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/bilateral_smooth_point_set.h>
#include <CGAL/jet_estimate_normals.h>
#include <CGAL/property_map.h>

#include <utility>
#include <vector>

#include "tests/bench/metrology_peers.h"

namespace scanprep::bench {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Vector = Kernel::Vector_3;
using PointWithNormal = std::pair<Point, Vector>;
#ifdef CGAL_LINKED_WITH_TBB
using Concurrency = CGAL::Parallel_tag;
#else
using Concurrency = CGAL::Sequential_tag;
#endif

auto Maps() {
  return CGAL::parameters::point_map(CGAL::First_of_pair_property_map<PointWithNormal>())
      .normal_map(CGAL::Second_of_pair_property_map<PointWithNormal>());
}

}  // namespace

PointCloud SmoothWithCgalBilateral(const PointCloud& raw, int k, double sharpness_deg,
                                   int iterations) {
  std::vector<PointWithNormal> points;
  points.reserve(raw.size());
  for (size_t i = 0; i < raw.size(); ++i) {
    points.push_back({Point(raw.x[i], raw.y[i], raw.z[i]), Vector(0, 0, 0)});
  }
  CGAL::jet_estimate_normals<Concurrency>(points, k, Maps());
  for (size_t i = 0; i < raw.size(); ++i) {
    const auto& camera = raw.scans[raw.scan[i]].camera_position;
    if (!camera) continue;
    const Vector to_camera(camera->x() - raw.x[i], camera->y() - raw.y[i], camera->z() - raw.z[i]);
    if (points[i].second * to_camera < 0) points[i].second = -points[i].second;
  }
  for (int round = 0; round < iterations; ++round) {
    CGAL::bilateral_smooth_point_set<Concurrency>(points, k, Maps().sharpness_angle(sharpness_deg));
  }
  PointCloud smoothed = raw;
  for (size_t i = 0; i < raw.size(); ++i) {
    smoothed.x[i] = static_cast<float>(points[i].first.x());
    smoothed.y[i] = static_cast<float>(points[i].first.y());
    smoothed.z[i] = static_cast<float>(points[i].first.z());
  }
  return smoothed;
}

}  // namespace scanprep::bench

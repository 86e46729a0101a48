// SPDX-License-Identifier: Apache-2.0
// Small measurements shared by the stage tests that run on simulated scans.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/base/point_cloud.h"

namespace scanprep::testing {
using namespace scanprep::sim;

// The q-quantile (0..1) of `values` (copied; empty → NaN).
inline double Quantile(std::vector<double> values, double q) {
  if (values.empty()) return std::nan("");
  const size_t at = std::min(values.size() - 1, static_cast<size_t>(q * values.size()));
  std::nth_element(values.begin(), values.begin() + at, values.end());
  return values[at];
}

// Unsigned angle (degrees) between the estimated normal of point i and a reference normal.
inline double AxisAngleDeg(const PointCloud& cloud, size_t i, const Eigen::Vector3f& truth) {
  const double c = std::abs(cloud.normal(i).cast<double>().dot(truth.cast<double>()));
  return std::acos(std::min(1.0, c)) * 180.0 / M_PI;
}

}  // namespace scanprep::testing

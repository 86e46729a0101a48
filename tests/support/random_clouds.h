// SPDX-License-Identifier: Apache-2.0
// Random clouds for tests that need many points spread over a known volume, not a scan: grid and
// memory tests whose property does not depend on the shape.
#pragma once

#include <cstddef>
#include <cstdint>
#include <random>

#include <Eigen/Core>

#include "core/base/point_cloud.h"

namespace scanprep::testing {

// `n` points uniform in the box [lo, hi] (per axis), from a fixed seed.
inline PointCloud UniformBoxCloud(size_t n, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi,
                                  uint32_t seed) {
  PointCloud cloud;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> x(lo.x(), hi.x()), y(lo.y(), hi.y()), z(lo.z(), hi.z());
  for (size_t i = 0; i < n; ++i) {
    cloud.x.push_back(x(rng));
    cloud.y.push_back(y(rng));
    cloud.z.push_back(z(rng));
  }
  cloud.FinishLoading();
  return cloud;
}

}  // namespace scanprep::testing

// SPDX-License-Identifier: Apache-2.0
// A ball's points copied next to each other as float offsets from its centre. The stages that
// test every point of a ball against several candidate planes (smoothing's own side, the outliers'
// surface test: up to eight planes, then refits) read three contiguous arrays that the compiler
// vectorises, instead of gathering x[j], y[j], z[j] from the cloud once per plane.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "core/base/point_cloud.h"
#include "core/spatial/cell_grid.h"

namespace scanprep {

class BallPoints {
 public:
  // The matched points' positions minus `centre`, in the matches' order.
  void Gather(const PointCloud& cloud, const RadiusMatches& matches,
              const Eigen::Vector3f& centre) {
    const size_t n = matches.size();
    x_.resize(n), y_.resize(n), z_.resize(n), offset_.resize(n);
    for (size_t k = 0; k < n; ++k) {
      const uint32_t j = matches[k].first;
      x_[k] = cloud.x[j] - centre.x(), y_[k] = cloud.y[j] - centre.y(),
      z_[k] = cloud.z[j] - centre.z();
    }
  }
  Eigen::Vector3f at(size_t k) const { return {x_[k], y_[k], z_[k]}; }

  // Signed offset of every point from the plane through `origin` (relative to the centre) with unit
  // `normal`, (p_k − origin)·normal; valid until the next call.
  const std::vector<float>& OffsetsFrom(const Eigen::Vector3f& origin,
                                        const Eigen::Vector3f& normal) {
    const float ox = origin.x(), oy = origin.y(), oz = origin.z();
    const float nx = normal.x(), ny = normal.y(), nz = normal.z();
    const size_t n = x_.size();
    const float* x = x_.data();
    const float* y = y_.data();
    const float* z = z_.data();
    float* out = offset_.data();
    for (size_t k = 0; k < n; ++k) out[k] = (x[k] - ox) * nx + (y[k] - oy) * ny + (z[k] - oz) * nz;
    return offset_;
  }

 private:
  std::vector<float> x_, y_, z_, offset_;
};

}  // namespace scanprep

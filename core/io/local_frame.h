// SPDX-License-Identifier: Apache-2.0
// Readers of formats that store coordinates in double or as scaled integers (LAS, PLY double,
// PCD F8, text, E57 with its poses) keep them exact in float by storing them relative to a round
// origin near the data (PointCloud::origin); the writers add it back in double.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "absl/status/status.h"
#include "core/base/point_cloud.h"

namespace scanprep::io {

// The origin for coordinates within [min, max]: zero when the box's centre lies within 16 times
// its extent of zero (every ordinary scan: its floats stay what they were), else its centre rounded
// to a power of ten no larger than the extent, so that local coordinates stay within about the
// extent and a round offset (a survey grid, a UTM easting) cancels exactly. Zero when the extent is
// not finite (a reader then reports the value that is).
Eigen::Vector3d LocalOrigin(const Eigen::Vector3d& min, const Eigen::Vector3d& max);

// Coordinates read in double, one slot per point, until the reader has seen them all; Narrow()
// then stores them in the cloud relative to LocalOrigin() of their finite values.
class WideCoordinates {
 public:
  void Resize(size_t n) { x_.resize(n), y_.resize(n), z_.resize(n); }
  void Reserve(size_t n) { x_.reserve(n), y_.reserve(n), z_.reserve(n); }
  size_t size() const { return x_.size(); }
  double& at(int axis, size_t i) { return (axis == 0 ? x_ : axis == 1 ? y_ : z_)[i]; }
  void Push(double x, double y, double z) { x_.push_back(x), y_.push_back(y), z_.push_back(z); }

  // Sets cloud.origin and cloud.x, y, z (one per point read); NaN and infinity stay as they are (a
  // scanner's "no measurement"). INVALID_ARGUMENT naming the point when a finite value is beyond
  // float's range from the origin. Frees the doubles.
  absl::Status Narrow(PointCloud& cloud, const std::string& name);

 private:
  std::vector<double> x_, y_, z_;
};

}  // namespace scanprep::io

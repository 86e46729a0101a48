// SPDX-License-Identifier: Apache-2.0
// What the point-cloud writers (PLY, PCD, XYZ) share: their options, the check that the cloud's
// arrays agree, the points they write, and writing to a file with the path in every error.
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <ostream>

#include "absl/status/status.h"
#include "core/base/point_cloud.h"

namespace scanprep::io {

struct WriteOptions {
  bool include_removed = false;  // also the points a stage removed, flagged
};

// INVALID_ARGUMENT naming the array when an optional per-point array is neither empty nor one
// entry per point ("cannot write <format>: cloud.nx has 3 entries for 4 points").
absl::Status CheckWritable(const PointCloud& cloud, const char* format);

// Whether point i is written: every point with include_removed, else the kept ones.
inline bool Written(const PointCloud& cloud, size_t i, const WriteOptions& options) {
  return options.include_removed || cloud.flags.empty() || !cloud.removed(i);
}
size_t WrittenCount(const PointCloud& cloud, const WriteOptions& options);

// A cloud with an origin is written with double coordinates, origin + local, so that a file far
// from zero keeps what float could not; one without keeps float coordinates as it always had.
inline bool WritesDoubleCoordinates(const PointCloud& cloud) { return !cloud.origin.isZero(0); }
inline Eigen::Vector3d WorldPoint(const PointCloud& cloud, size_t i) {
  return cloud.origin + Eigen::Vector3d(cloud.x[i], cloud.y[i], cloud.z[i]);
}

// Opens `path` (binary, truncated), runs `write` on it and closes it; errors name the path.
absl::Status WriteFile(const std::filesystem::path& path,
                       const std::function<absl::Status(std::ostream&)>& write);

}  // namespace scanprep::io

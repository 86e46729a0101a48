// SPDX-License-Identifier: Apache-2.0
// What the point-cloud writers (PLY, PCD, XYZ) share: their options, the check that the cloud's
// arrays agree, the points they write, and writing to a file with the path in every error.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <initializer_list>
#include <ostream>
#include <string_view>

#include "absl/status/status.h"
#include "core/base/point_cloud.h"

namespace scanprep::io {

struct WriteOptions {
  bool include_removed = false;  // also the points a stage removed, flagged
};

// INVALID_ARGUMENT naming the array when an optional per-point array is neither empty nor one
// entry per point ("cannot write <format>: cloud.nx has 3 entries for 4 points").
absl::Status CheckWritable(const PointCloud& cloud, const char* format);

// The cloud's attributes as fields of a file that also writes the fields `written`: each a word
// of printable ASCII (as PLY and PCD headers separate names by spaces) that none of them and no
// other attribute has (INVALID_ARGUMENT naming it), so the file reads back unambiguously.
absl::Status CheckAttributeNames(const PointCloud& cloud, const char* format,
                                 std::initializer_list<std::string_view> written);

// Calls put(v) with `value` as the C++ type of `type`: exact, as it was read from one.
template <class Put>
void PutAttributeValue(AttributeType type, double value, Put&& put) {
  switch (type) {
    case AttributeType::kInt8:
      return put(static_cast<int8_t>(value));
    case AttributeType::kUint8:
      return put(static_cast<uint8_t>(value));
    case AttributeType::kInt16:
      return put(static_cast<int16_t>(value));
    case AttributeType::kUint16:
      return put(static_cast<uint16_t>(value));
    case AttributeType::kInt32:
      return put(static_cast<int32_t>(value));
    case AttributeType::kUint32:
      return put(static_cast<uint32_t>(value));
    case AttributeType::kFloat32:
      return put(static_cast<float>(value));
    case AttributeType::kFloat64:
      return put(value);
    case AttributeType::kFloat32Bits:
      return put(std::bit_cast<float>(static_cast<uint32_t>(value)));
  }
}

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

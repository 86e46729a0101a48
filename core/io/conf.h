// SPDX-License-Identifier: Apache-2.0
// Stanford / scanalyze `.conf` registration files.
#pragma once

#include <filesystem>
#include <istream>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "absl/status/statusor.h"

namespace scanprep::io {

// x_common = rotation * x_scan + translation
struct RigidPose {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
};

inline Eigen::Vector3d Apply(const RigidPose& pose, const Eigen::Vector3d& x_scan) {
  return pose.rotation * x_scan + pose.translation;
}

struct ConfEntry {
  std::string file;
  RigidPose pose;
};

// Lines "bmesh <file> tx ty tz qx qy qz qw" (also "mesh"); "camera" lines, blank lines and '#'
// comments are ignored. scanalyze stores the inverse rotation: X_world = R(q)^T X_scan + t for
// q = (qx,qy,qz,qw), so the returned rotation is the conjugate of the normalised q.
absl::StatusOr<std::vector<ConfEntry>> ReadConf(const std::filesystem::path& path);
absl::StatusOr<std::vector<ConfEntry>> ReadConf(std::istream& in,
                                                const std::string& name_for_errors);

}  // namespace scanprep::io

// SPDX-License-Identifier: Apache-2.0
#include "core/spatial/view_geometry.h"

#include <algorithm>
#include <cmath>

namespace scanprep {

std::optional<Eigen::Vector3d> TowardCamera(const ScanMeta& scan, const Eigen::Vector3d& p) {
  if (scan.camera_position) return *scan.camera_position - p;
  if (scan.view_direction) return *scan.view_direction;
  return std::nullopt;
}

std::optional<Eigen::Vector3d> TowardProjector(const ScanMeta& scan, const Eigen::Vector3d& p) {
  if (scan.projector_position) return *scan.projector_position - p;
  if (scan.projector_direction) return *scan.projector_direction;
  return std::nullopt;
}

double ViewAngle(const Eigen::Vector3d& n, const Eigen::Vector3d& toward) {
  const double norm = toward.norm();
  if (!(norm > 0)) return 0;
  return std::acos(std::clamp(std::abs(n.dot(toward)) / norm, 0.0, 1.0));
}

}  // namespace scanprep

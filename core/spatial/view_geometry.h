// SPDX-License-Identifier: Apache-2.0
// Where a scan's sensors look from: the directions from a surface point toward its camera and
// projector, and the viewing angle a normal makes with one. The measures stage's viewing
// quality (§8) and the health stage's viewing angles are both built on these.
#pragma once

#include <optional>

#include <Eigen/Core>

#include "core/base/point_cloud.h"

namespace scanprep {

// The direction from surface point p toward scan's camera (camera_position − p, or the line
// scanner's view_direction); none without either.
std::optional<Eigen::Vector3d> TowardCamera(const ScanMeta& scan, const Eigen::Vector3d& p);
// The same toward its projector (projector_position − p, or projector_direction).
std::optional<Eigen::Vector3d> TowardProjector(const ScanMeta& scan, const Eigen::Vector3d& p);
// Angle in [0, π/2] between the unoriented normal n and a direction.
double ViewAngle(const Eigen::Vector3d& n, const Eigen::Vector3d& toward);

}  // namespace scanprep

// SPDX-License-Identifier: Apache-2.0
// What the registration stage did to each scan: the rigid motion it applied and the residuals
// against the other scans before and after. Read by the report, the CLI and the Python client.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include <Eigen/Core>

namespace scanprep {

struct ScanRegistration {
  uint32_t scan = 0;  // index into the cloud's scans
  std::string scan_id;
  // Held where it is: the scan with the most points of its group of overlapping scans.
  bool reference = false;
  // The motion applied to the scan's points, normals and pose: a rotation by the rotation vector
  // `rotation_deg` (degrees) about `centre` (common frame, mm, relative to the cloud's origin),
  // then a translation by `translation_mm`. Zero for a reference or a scan left where it was.
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d rotation_deg = Eigen::Vector3d::Zero();
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  // The directions of its motion (of six) its overlaps constrain: it moved along these only.
  int constrained_directions = 0;
  // The RMS distance of its points from the other scans' local planes, robustly (√(median² +
  // spread²) of the signed point-to-plane residuals, mm), before the first step and after the
  // last; absent where no other scan overlaps it enough.
  std::optional<double> residual_before_mm, residual_after_mm;
  int iterations = 0;  // steps applied
  // The correction it needed exceeded registration.max_correction: left where it was, with
  // a REGISTRATION_BOUND_EXCEEDED warning.
  bool bound_exceeded = false;
};

}  // namespace scanprep

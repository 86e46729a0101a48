// SPDX-License-Identifier: Apache-2.0
// Scanner health: what one job says about the sensors that took its scans (the paper keeps the
// raw uncertainties "to evaluate the acquisition quality of the scanner"). Filled by the "health"
// stage from what the pipeline measures anyway; read by the report, the server's per-sensor
// metrics, the CLI's table and the Python client.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace scanprep {

// One scan of the job.
struct ScanHealth {
  uint32_t scan = 0;  // index into the cloud's scans
  std::string scan_id;
  std::string sensor_id;  // ScanMeta::sensor_id; empty = not stated
  uint64_t points = 0;    // the scan's points that entered the pipeline
  // σ̂: the median RMS residual of the scan's own normal fits (mm); absent when fewer than
  // kMinNoiseSamples fits are valid.
  std::optional<double> noise_mm;
  // σ̂ / u, absent when the job stated no u or σ̂ is absent.
  std::optional<double> noise_to_uncertainty;
  // Shares of `points`: removed as outliers, merged away by the correction stage (absent when the
  // stage did not run before health); and of points + ScanMeta::points_invalid, the scan's
  // unmeasured points (left out by a reader or the server).
  std::optional<double> outlier_share;
  std::optional<double> merged_share;
  double invalid_share = 0;
  // Viewing angle (degrees, between the normal and the direction to the camera) over the scan's
  // points with a valid normal: 10th, 50th and 90th percentile; absent without a camera.
  std::optional<std::array<double, 3>> viewing_angle_deg;
};

// Rigid misalignment components, in this order: translations along x, y, z of the common frame
// (mm), then rotations about x, y, z through `PairHealth::centre` (degrees).
inline constexpr std::array<const char*, 6> kMisalignmentAxes = {"tx", "ty", "tz",
                                                                 "rx", "ry", "rz"};

// The standard errors of components nothing was solved for.
inline Eigen::Vector3d UnsolvedErrors() {
  return Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
}

// One pair of scans that overlap. `moving`'s points are compared with `fixed`'s local planes;
// every signed distance and the misalignment say where `moving` lies relative to `fixed`.
struct PairHealth {
  uint32_t fixed = 0, moving = 0;  // scan indices
  uint64_t overlap_points = 0;     // moving's points used (each had a plane of `fixed`)
  // Signed point-to-plane distance (mm, along fixed's normal): median, and the robust spread
  // 1.4826 · MAD.
  double residual_median_mm = 0;
  double residual_spread_mm = 0;
  // Overlap centroid (common frame, mm, relative to the cloud's origin) the rotations are about.
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  // The rigid motion that maps `fixed`'s surface onto `moving`'s points, linearised: translation
  // (mm) at `centre` and rotation vector (degrees). A component the overlap cannot constrain
  // (too small, or too flat in that direction) is flagged in `constrained` and reported as 0.
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d rotation_deg = Eigen::Vector3d::Zero();
  // Each component's standard error, from the least-squares covariance (the whitened residuals'
  // spread squared times (JᵀJ)⁻¹, or the jackknife's over groups of the overlap where that is
  // larger), in the component's unit; given for unconstrained ones too, infinite where the
  // overlap holds nothing at all along the component, or the pair is too small to be solved.
  Eigen::Vector3d translation_se_mm = UnsolvedErrors();
  Eigen::Vector3d rotation_se_deg = UnsolvedErrors();
  std::array<bool, 6> constrained{};  // kMisalignmentAxes order
  // Why a component is unconstrained, e.g. "overlap too small (812 points < 1000)" or
  // "too flat to constrain tx, ty, rz"; empty when all six are constrained.
  std::string note;
};

// Pairs a report holds at most: those with the most overlap points (the parameter
// health.pairs_left_out counts the rest), so a job of many overlapping scans does not make a
// report and per-sensor series that grow with the square of its scans.
inline constexpr size_t kMaxReportedPairs = 256;

struct HealthReport {
  std::vector<ScanHealth> scans;  // one per scan, in scan order
  std::vector<PairHealth> pairs;  // overlapping pairs, fixed < moving
};

}  // namespace scanprep

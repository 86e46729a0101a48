// SPDX-License-Identifier: Apache-2.0
// Translation between the wire messages (job units, per-scan frames) and core's types
// (millimetres, one common frame). Shared by the server and the client (its preview moves the
// sent scans exactly as the server does).
#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "absl/status/statusor.h"
#include "core/base/point_cloud.h"
#include "core/pipeline/pipeline.h"
#include "core/pipeline/presets.h"
#include "core/stages/report.h"
#include "core/stages/warning.h"
#include "scanprep/v1/scanprep.pb.h"
#include "wire/warning_codes.h"

namespace scanprep {

// Largest coordinate magnitude accepted after conversion to millimetres (1,000 km). Beyond it a
// float keeps less than 0.1 mm of resolution, and a little further it overflows.
inline constexpr double kMaxCoordinateMm = 1e9;
// The range of a scanline spacing, uncertainty or point spacing other than 0 (= none, or the
// default), in millimetres. The top is the bound of the stages' own length parameters: a 10 m
// spacing is no optical scanner's, and 1e300 made the stages derive radii that swallowed the
// whole cloud. The bottom, 1 nm, is below any optical scanner's resolution; 1e-300 underflowed
// the derived spacings to 0, which a later stage reported as a fault of the data.
inline constexpr double kMinScannerLengthMm = 1e-6;
inline constexpr double kMaxScannerLengthMm = 1e4;

// Millimetres per job unit; INVALID_ARGUMENT for LENGTH_UNIT_UNSPECIFIED or an unknown value.
absl::StatusOr<double> MillimetresPerUnit(v1::LengthUnit unit);

// Largest JobHeader.origin, ScanHeader.points_offset or to_common translation, in millimetres
// (100,000 km: any georeferenced frame); double keeps 1e-5 mm there.
inline constexpr double kMaxOffsetMm = 1e11;

// Maps a point of one scan (job units, scan frame) into the job's local frame in millimetres:
// the common frame less JobHeader.origin, all in double.
struct ScanFrame {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  // to_common's translation less the job's origin: where the scan frame's zero lies locally.
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();
  // The same for the points on the wire, which are relative to the scan's points_offset:
  // rotation * points_offset + translation_mm, so that a point needs one product and one sum.
  Eigen::Vector3d points_translation_mm = Eigen::Vector3d::Zero();
  double mm_per_unit = 1.0;

  // A position of the header (absolute in the scan frame).
  Eigen::Vector3d Point(const Eigen::Vector3d& p) const {
    return rotation * (p * mm_per_unit) + translation_mm;
  }
  // A point of a chunk (relative to points_offset).
  Eigen::Vector3d ChunkPoint(const Eigen::Vector3d& p) const {
    return rotation * (p * mm_per_unit) + points_translation_mm;
  }
  Eigen::Vector3d Direction(const Eigen::Vector3d& d) const { return rotation * d; }
};

// JobHeader.origin in millimetres: zero when absent; INVALID_HEADER naming header.origin when
// not finite or beyond kMaxOffsetMm.
absl::StatusOr<Eigen::Vector3d> OriginFromProto(const v1::JobHeader& header, double mm_per_unit);

// The scan's frame from its to_common and points_offset, relative to the job's origin (mm);
// `field` names it in errors (e.g. "header.scans[2]").
absl::StatusOr<ScanFrame> FrameFromProto(const v1::ScanHeader& scan, double mm_per_unit,
                                         const Eigen::Vector3d& origin_mm, std::string_view field);

// The spacing of floats at a local coordinate (infinite or NaN beyond float's range).
double FloatSpacingAt(double mm);
// A local coordinate is held as a float only where that spacing is at most this share of the
// scan's uncertainty u: rounding then moves a point by at most u/8 (1.6 % of u² in the noise).
inline constexpr double kMaxFloatSpacingPerUncertainty = 0.25;

// ScanHeader.sensor_id: at most this many bytes, each one of [A-Za-z0-9._:-].
inline constexpr size_t kMaxSensorIdBytes = 64;
constexpr bool IsSensorIdChar(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' ||
         c == '_' || c == ':' || c == '-';
}

// The scan's metadata in the common frame and in millimetres. A zero uncertainty becomes the
// default 0.1 mm; directions are normalised. INVALID_METADATA naming the field for a bad value,
// sensor_id included (kMaxSensorIdBytes, IsSensorIdChar).
absl::StatusOr<ScanMeta> ScanMetaFromProto(const v1::ScanHeader& scan, const ScanFrame& frame,
                                           std::string_view field);

// LINE when stated, or when unspecified and any scan has a scanline spacing.
ScannerKind KindFromHeader(const v1::JobHeader& header);

// Stages, overrides and budgets. A zero total budget becomes `default_budget_seconds`; the
// header's stage budgets replace the defaults of the stages they name (0 there = no budget).
PipelineOptions OptionsFromHeader(const v1::JobHeader& header, double default_budget_seconds,
                                  const std::map<std::string, double>& default_stage_seconds);

// options.fail_on as core's codes; INVALID_ARGUMENT naming options.fail_on[i] (a FieldError)
// for WARNING_CODE_UNSPECIFIED or a number this server does not know.
absl::StatusOr<std::set<WarningCode>> FailOnFromProto(const v1::PipelineOptions& options);

// One warning into both of the report's lists: `warnings` (text) and `warning_details`.
void AddWarning(const Warning& warning, v1::Report* out);

// The pipeline's report, health included (pairs named by their scans' ids; unconstrained
// misalignment components by their kMisalignmentAxes names).
void ReportToProto(const PipelineReport& report, v1::Report* out);

// A parameter's declaration as GetInfo() lists it: kind, default and valid range.
void ParamSpecToProto(const ParamSpec& spec, v1::ParameterInfo* out);

// A preset as GetInfo() lists it: its name, description and overrides.
void PresetToProto(const Preset& preset, v1::PresetInfo* out);

// Writes points [begin, end) of `indices` into `out`, coordinates (relative to the job's origin)
// divided by `mm_per_unit`.
void ResultChunk(const PointCloud& cloud, const std::vector<uint32_t>& indices, size_t begin,
                 size_t end, double mm_per_unit, v1::PointChunk* out);

}  // namespace scanprep

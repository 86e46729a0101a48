// SPDX-License-Identifier: Apache-2.0
#include "wire/convert.h"

#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"
#include "core/base/field_error.h"
#include "core/base/status_macros.h"
#include "wire/error_details.h"

namespace scanprep {
namespace {

Eigen::Vector3d FromProto(const v1::Vec3& v) { return {v.x(), v.y(), v.z()}; }

v1::Vec3 ToProto(const Eigen::Vector3d& v) {
  v1::Vec3 out;
  out.set_x(v.x());
  out.set_y(v.y());
  out.set_z(v.z());
  return out;
}

bool Finite(const Eigen::Vector3d& v) { return v.allFinite(); }

v1::BudgetOutcome Outcome(double budget_seconds, bool met) {
  if (budget_seconds <= 0) return v1::BUDGET_OUTCOME_NO_BUDGET;
  return met ? v1::BUDGET_OUTCOME_MET : v1::BUDGET_OUTCOME_MISSED;
}

// INVALID_METADATA "<scan>.<name>: <problem>", naming the field.
absl::Status BadField(std::string_view field, std::string_view name, std::string_view problem) {
  const std::string path = absl::StrCat(std::string(field), ".", std::string(name));
  return WithFieldViolation(
      absl::InvalidArgumentError(absl::StrCat(path, ": ", std::string(problem))),
      "INVALID_METADATA", path);
}

// A length in job units, converted to mm: 0, or within [kMinScannerLengthMm, kMaxScannerLengthMm].
absl::StatusOr<double> Length(double value, double mm_per_unit, std::string_view field,
                              std::string_view name) {
  const double mm = value * mm_per_unit;
  if (!(mm == 0 || (mm >= kMinScannerLengthMm && mm <= kMaxScannerLengthMm))) {
    return BadField(field, name,
                    absl::StrCat("must be 0 or a length in [", kMinScannerLengthMm, ", ",
                                 kMaxScannerLengthMm, "] mm, got ", value, " (", mm, " mm)"));
  }
  return mm;
}

absl::StatusOr<Eigen::Vector3d> Position(const v1::Vec3& v, const ScanFrame& frame,
                                         std::string_view field, std::string_view name) {
  const Eigen::Vector3d p = FromProto(v);
  if (!Finite(p)) return BadField(field, name, "must be finite");
  const Eigen::Vector3d mm = frame.Point(p);
  if (!(mm.array().abs() <= kMaxCoordinateMm).all()) {
    return BadField(field, name,
                    absl::StrCat("must be within ", kMaxCoordinateMm,
                                 " mm of the origin in the "
                                 "common frame"));
  }
  return mm;
}

absl::StatusOr<Eigen::Vector3d> Direction(const v1::Vec3& v, const ScanFrame& frame,
                                          std::string_view field, std::string_view name) {
  const Eigen::Vector3d d = FromProto(v);
  // stableNorm: the plain norm of components near 1e200 overflows, and normalising by infinity
  // would turn the direction into a zero vector.
  const double norm = Finite(d) ? d.stableNorm() : 0;
  if (!(norm > 0 && std::isfinite(norm))) {
    return BadField(field, name, "must be a finite non-zero vector");
  }
  return frame.Direction(d / norm);
}

// ScanHeader.sensor_id becomes a Prometheus label value and a key across jobs: a short name of
// characters that need no escaping anywhere (no quotes, spaces or "|", which joins a pair's ids).
absl::Status CheckSensorId(std::string_view id, std::string_view field) {
  if (id.size() > kMaxSensorIdBytes) {
    return BadField(field, "sensor_id",
                    absl::StrCat("must be at most ", kMaxSensorIdBytes, " bytes, got ", id.size()));
  }
  for (const char c : id) {
    if (!IsSensorIdChar(c)) {
      return BadField(field, "sensor_id",
                      absl::StrCat("may hold only A-Z a-z 0-9 . _ : -, got byte ",
                                   static_cast<int>(static_cast<unsigned char>(c))));
    }
  }
  return absl::OkStatus();
}

void RegistrationToProto(const ScanRegistration& scan, v1::ScanRegistration* out) {
  out->set_scan_id(scan.scan_id);
  out->set_reference(scan.reference);
  *out->mutable_translation_mm() = ToProto(scan.translation_mm);
  *out->mutable_rotation_deg() = ToProto(scan.rotation_deg);
  *out->mutable_centre() = ToProto(scan.centre);
  out->set_constrained_directions(scan.constrained_directions);
  if (scan.residual_before_mm) out->set_residual_before_mm(*scan.residual_before_mm);
  if (scan.residual_after_mm) out->set_residual_after_mm(*scan.residual_after_mm);
  out->set_iterations(scan.iterations);
  out->set_bound_exceeded(scan.bound_exceeded);
}

void HealthToProto(const HealthReport& health, v1::HealthReport* out) {
  for (const ScanHealth& scan : health.scans) {
    v1::ScanHealth* s = out->add_scans();
    s->set_scan_id(scan.scan_id);
    s->set_sensor_id(scan.sensor_id);
    s->set_points(scan.points);
    if (scan.noise_mm) s->set_noise_mm(*scan.noise_mm);
    if (scan.noise_to_uncertainty) s->set_noise_to_uncertainty(*scan.noise_to_uncertainty);
    if (scan.outlier_share) s->set_outlier_share(*scan.outlier_share);
    if (scan.merged_share) s->set_merged_share(*scan.merged_share);
    s->set_invalid_share(scan.invalid_share);
    if (scan.viewing_angle_deg) {
      for (const double p : *scan.viewing_angle_deg) s->add_viewing_angle_percentiles_deg(p);
    }
  }
  // The pair names its scans by index; the wire by the ids the client sent (health.scans is one
  // per scan of the cloud, in scan order).
  const auto scan_of = [&](uint32_t index) -> const ScanHealth* {
    return index < health.scans.size() ? &health.scans[index] : nullptr;
  };
  for (const PairHealth& pair : health.pairs) {
    v1::PairHealth* p = out->add_pairs();
    if (const ScanHealth* fixed = scan_of(pair.fixed)) {
      p->set_fixed_scan_id(fixed->scan_id);
      p->set_fixed_sensor_id(fixed->sensor_id);
    }
    if (const ScanHealth* moving = scan_of(pair.moving)) {
      p->set_moving_scan_id(moving->scan_id);
      p->set_moving_sensor_id(moving->sensor_id);
    }
    p->set_overlap_points(pair.overlap_points);
    p->set_residual_median_mm(pair.residual_median_mm);
    p->set_residual_spread_mm(pair.residual_spread_mm);
    *p->mutable_translation_mm() = ToProto(pair.translation_mm);
    *p->mutable_rotation_deg() = ToProto(pair.rotation_deg);
    *p->mutable_centre() = ToProto(pair.centre);
    *p->mutable_translation_se_mm() = ToProto(pair.translation_se_mm);
    *p->mutable_rotation_se_deg() = ToProto(pair.rotation_se_deg);
    for (size_t k = 0; k < kMisalignmentAxes.size(); ++k) {
      if (!pair.constrained[k]) p->add_unconstrained(kMisalignmentAxes[k]);
    }
    p->set_note(pair.note);
  }
}

}  // namespace

absl::StatusOr<double> MillimetresPerUnit(v1::LengthUnit unit) {
  switch (unit) {
    case v1::LENGTH_UNIT_MILLIMETRE:
      return 1.0;
    case v1::LENGTH_UNIT_METRE:
      return 1000.0;
    case v1::LENGTH_UNIT_MICROMETRE:
      return 0.001;
    case v1::LENGTH_UNIT_INCH:
      return 25.4;
    default:
      return WithFieldViolation(
          absl::InvalidArgumentError("header.unit: the length unit must be stated (MILLIMETRE, "
                                     "METRE, MICROMETRE or INCH)"),
          "INVALID_HEADER", "header.unit");
  }
}

absl::StatusOr<Eigen::Vector3d> OriginFromProto(const v1::JobHeader& header, double mm_per_unit) {
  const Eigen::Vector3d origin = FromProto(header.origin()) * mm_per_unit;
  if (!(origin.array().abs() <= kMaxOffsetMm).all()) {
    return WithFieldViolation(
        absl::InvalidArgumentError(absl::StrCat("header.origin: must be finite and within ",
                                                kMaxOffsetMm, " mm of the common frame's zero")),
        "INVALID_HEADER", "header.origin");
  }
  return origin;
}

absl::StatusOr<ScanFrame> FrameFromProto(const v1::ScanHeader& scan, double mm_per_unit,
                                         const Eigen::Vector3d& origin_mm, std::string_view field) {
  ScanFrame frame;
  frame.mm_per_unit = mm_per_unit;
  const Eigen::Vector3d points_offset_mm = FromProto(scan.points_offset()) * mm_per_unit;
  if (!(points_offset_mm.array().abs() <= kMaxOffsetMm).all()) {
    return BadField(field, "points_offset",
                    absl::StrCat("must be finite and within ", kMaxOffsetMm, " mm"));
  }
  const v1::RigidTransform& t = scan.to_common();
  if (t.has_rotation()) {
    const v1::Quaternion& q = t.rotation();
    Eigen::Quaterniond rotation(q.w(), q.x(), q.y(), q.z());
    const double norm = rotation.norm();
    if (!std::isfinite(norm) || std::abs(norm - 1.0) > 1e-3) {
      return BadField(field, "to_common.rotation",
                      absl::StrCat("must be a unit quaternion, its norm is ", norm));
    }
    frame.rotation = rotation.normalized().toRotationMatrix();
  }
  if (t.has_translation()) {
    const Eigen::Vector3d translation = FromProto(t.translation());
    frame.translation_mm = translation * mm_per_unit;
    // Far is fine now that the job's origin takes it out; beyond kMaxOffsetMm double itself
    // would lose the data's resolution.
    if (!(frame.translation_mm.array().abs() <= kMaxOffsetMm).all()) {
      return BadField(field, "to_common.translation",
                      absl::StrCat("must be finite and within ", kMaxOffsetMm, " mm"));
    }
  }
  frame.translation_mm -= origin_mm;
  frame.points_translation_mm = frame.rotation * points_offset_mm + frame.translation_mm;
  return frame;
}

double FloatSpacingAt(double mm) {
  const float narrow = std::abs(static_cast<float>(mm));
  return std::nextafter(narrow, std::numeric_limits<float>::infinity()) - narrow;
}

absl::StatusOr<ScanMeta> ScanMetaFromProto(const v1::ScanHeader& scan, const ScanFrame& frame,
                                           std::string_view field) {
  ScanMeta meta;
  meta.id = scan.scan_id();
  SCANPREP_RETURN_IF_ERROR(CheckSensorId(scan.sensor_id(), field));
  meta.sensor_id = scan.sensor_id();
  meta.points_invalid = scan.points_unmeasured();
  if (scan.has_camera_position()) {
    SCANPREP_ASSIGN_OR_RETURN(meta.camera_position,
                              Position(scan.camera_position(), frame, field, "camera_position"));
  }
  if (scan.has_projector_position()) {
    SCANPREP_ASSIGN_OR_RETURN(meta.projector_position, Position(scan.projector_position(), frame,
                                                                field, "projector_position"));
  }
  if (scan.has_view_direction()) {
    SCANPREP_ASSIGN_OR_RETURN(meta.view_direction,
                              Direction(scan.view_direction(), frame, field, "view_direction"));
  }
  if (scan.has_projector_direction()) {
    SCANPREP_ASSIGN_OR_RETURN(meta.projector_direction, Direction(scan.projector_direction(), frame,
                                                                  field, "projector_direction"));
  }
  auto spacing = Length(scan.scanline_spacing(), frame.mm_per_unit, field, "scanline_spacing");
  auto uncertainty = Length(scan.uncertainty(), frame.mm_per_unit, field, "uncertainty");
  auto point_spacing = Length(scan.point_spacing(), frame.mm_per_unit, field, "point_spacing");
  for (const auto* s : {&spacing, &uncertainty, &point_spacing}) {
    if (!s->ok()) return s->status();
  }
  meta.scanline_spacing = *spacing;
  if (*uncertainty > 0) meta.uncertainty = *uncertainty;
  meta.uncertainty_stated = *uncertainty > 0;
  meta.point_spacing = *point_spacing;
  return meta;
}

ScannerKind KindFromHeader(const v1::JobHeader& header) {
  switch (header.scanner_kind()) {
    case v1::SCANNER_KIND_LINE:
      return ScannerKind::kLine;
    case v1::SCANNER_KIND_FLEXIBLE:
      return ScannerKind::kFlexible;
    default:
      for (const v1::ScanHeader& scan : header.scans()) {
        if (scan.scanline_spacing() > 0) return ScannerKind::kLine;
      }
      return ScannerKind::kFlexible;
  }
}

PipelineOptions OptionsFromHeader(const v1::JobHeader& header, double default_budget_seconds,
                                  const std::map<std::string, double>& default_stage_seconds) {
  PipelineOptions options;
  options.stages.assign(header.options().stages().begin(), header.options().stages().end());
  for (const auto& [name, value] : header.options().params()) options.params[name] = value;
  options.budget_seconds = header.budget().total_seconds() != 0 ? header.budget().total_seconds()
                                                                : default_budget_seconds;
  options.stage_budget_seconds = default_stage_seconds;
  for (const auto& [name, seconds] : header.budget().stage_seconds()) {
    options.stage_budget_seconds[name] = seconds;
  }
  return options;
}

void ReportToProto(const PipelineReport& report, v1::Report* out) {
  for (const StageReport& stage : report.stages) {
    v1::StageReport* s = out->add_stages();
    s->set_name(stage.name);
    s->set_points_in(stage.points_in);
    s->set_points_out(stage.points_out);
    s->set_seconds(stage.seconds);
    for (const auto& [name, value] : stage.parameters) (*s->mutable_parameters())[name] = value;
    for (const auto& [name, value] : stage.text_parameters) {
      (*s->mutable_text_parameters())[name] = value;
    }
    s->set_budget_seconds(stage.budget_seconds);
    s->set_budget_met(stage.budget_met);
    s->set_budget_outcome(Outcome(stage.budget_seconds, stage.budget_met));
  }
  out->set_processing_seconds(report.total_seconds);
  out->set_budget_seconds(report.budget_seconds);
  out->set_budget_met(report.budget_met);
  out->set_budget_outcome(Outcome(report.budget_seconds, report.budget_met));
  out->set_points_coincident_across_scans(report.points_coincident_across_scans);
  out->set_estimated_plan_cost(report.estimated_plan_cost);
  for (const Warning& w : report.warnings) AddWarning(w, out);
  if (report.health) HealthToProto(*report.health, out->mutable_health());
  for (const ScanRegistration& scan : report.registration) {
    RegistrationToProto(scan, out->add_registration());
  }
}

absl::StatusOr<std::set<WarningCode>> FailOnFromProto(const v1::PipelineOptions& options) {
  std::set<WarningCode> codes;
  for (int i = 0; i < options.fail_on_size(); ++i) {
    const std::optional<WarningCode> code = WarningCodeFromProto(options.fail_on(i));
    if (!code) {
      return FieldError(absl::StrCat("options.fail_on[", i, "]"),
                        absl::StrCat(options.fail_on(i), " is not a warning code of this server"));
    }
    codes.insert(*code);
  }
  return codes;
}

void AddWarning(const Warning& warning, v1::Report* out) {
  out->add_warnings(warning.message);
  v1::Warning* detail = out->add_warning_details();
  detail->set_code(WarningCodeToProto(warning.code));
  detail->set_message(warning.message);
  detail->mutable_params()->insert(warning.params.begin(), warning.params.end());
}

void ParamSpecToProto(const ParamSpec& spec, v1::ParameterInfo* out) {
  out->set_name(spec.name);
  out->set_description(spec.description);
  out->set_default_value(spec.default_text);
  for (const std::string& c : spec.choices) out->add_choices(c);
  switch (spec.kind) {
    case ParamKind::kReal:
      out->set_kind(v1::PARAMETER_KIND_REAL);
      break;
    case ParamKind::kInteger:
      out->set_kind(v1::PARAMETER_KIND_INTEGER);
      break;
    case ParamKind::kChoice:
      out->set_kind(v1::PARAMETER_KIND_CHOICE);
      return;
  }
  out->set_default_derived(!spec.default_value.has_value());
  out->set_min(spec.range.min);
  out->set_max(spec.range.max);
  out->set_min_inclusive(spec.range.min_inclusive);
  out->set_max_inclusive(spec.range.max_inclusive);
  out->set_range(spec.range.ToString());
  out->set_at_most(spec.at_most);
}

void PresetToProto(const Preset& preset, v1::PresetInfo* out) {
  out->set_name(preset.name);
  out->set_description(preset.description);
  out->mutable_params()->insert(preset.params.begin(), preset.params.end());
  out->set_built_in(preset.built_in);
}

void ResultChunk(const PointCloud& cloud, const std::vector<uint32_t>& indices, size_t begin,
                 size_t end, double mm_per_unit, v1::PointChunk* out) {
  const size_t n = end - begin;
  const float scale = static_cast<float>(1.0 / mm_per_unit);
  out->mutable_xyz()->Reserve(3 * n);
  out->mutable_scan_index()->Reserve(n);
  if (cloud.has_normals()) out->mutable_normal()->Reserve(3 * n);
  std::string* flags = out->mutable_flags();
  flags->reserve(n);
  for (size_t k = begin; k < end; ++k) {
    const uint32_t i = indices[k];
    out->add_xyz(cloud.x[i] * scale);
    out->add_xyz(cloud.y[i] * scale);
    out->add_xyz(cloud.z[i] * scale);
    out->add_scan_index(cloud.scan[i]);
    if (cloud.has_scanlines()) out->add_scanline(cloud.scanline[i]);
    if (!cloud.quality.empty()) out->add_quality(cloud.quality[i]);
    if (!cloud.intensity.empty()) out->add_intensity(cloud.intensity[i]);
    if (cloud.has_normals()) {
      out->add_normal(cloud.nx[i]);
      out->add_normal(cloud.ny[i]);
      out->add_normal(cloud.nz[i]);
    }
    flags->push_back(static_cast<char>(cloud.flags[i]));
  }
}

}  // namespace scanprep

// The wire flag bits are core's bits; ResultChunk copies them unchanged.
static_assert(int{scanprep::kRemovedOutlier} == scanprep::v1::FLAG_REMOVED_OUTLIER &&
              int{scanprep::kRemovedMerge} == scanprep::v1::FLAG_REMOVED_MERGE &&
              int{scanprep::kRemovedSimplify} == scanprep::v1::FLAG_REMOVED_SIMPLIFY &&
              int{scanprep::kSmoothed} == scanprep::v1::FLAG_SMOOTHED &&
              int{scanprep::kNormalInvalid} == scanprep::v1::FLAG_NORMAL_INVALID &&
              int{scanprep::kEdge} == scanprep::v1::FLAG_EDGE);

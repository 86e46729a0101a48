// SPDX-License-Identifier: Apache-2.0
#include "server/job/job_assembler.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "core/base/status_macros.h"
#include "core/pipeline/plan_cost.h"
#include "wire/chunk_arrays.h"
#include "wire/error_details.h"

namespace scanprep::server {
namespace {

// INVALID_CHUNK "chunk <index>: <problem>", naming points[<index>].<array> (the index-th
// PointChunk message; no array when the message as a whole is at fault).
absl::Status BadChunk(uint64_t chunk, std::string_view array, std::string_view problem) {
  return WithFieldViolation(
      absl::InvalidArgumentError(absl::StrCat("chunk ", chunk, ": ", std::string(problem))),
      "INVALID_CHUNK",
      absl::StrCat("points[", chunk, "]", array.empty() ? "" : ".", std::string(array)));
}

// POINTS_INVALID: how many points were left out and why, and the first few in upload order.
Warning PointsInvalidWarning(const AssembledJob& job) {
  const uint64_t unrepresentable = job.points_unrepresentable;
  std::vector<std::string> causes;
  if (const uint64_t bad = job.points_invalid - unrepresentable; bad > 0) {
    causes.push_back(absl::StrCat(bad, " with NaN, infinite or out-of-range (> ", kMaxCoordinateMm,
                                  " mm) coordinates"));
  }
  if (unrepresentable > 0) {
    causes.push_back(absl::StrCat(unrepresentable,
                                  " too far from header.origin, or sent as floats too far from "
                                  "their scan's points_offset, for float to hold them to their "
                                  "scan's uncertainty"));
  }
  return {WarningCode::kPointsInvalid,
          absl::StrCat(
              job.points_invalid, " of ", job.points_received,
              " points were excluded: ", absl::StrJoin(causes, ", "),
              " (the first, in upload order: ", absl::StrJoin(job.first_invalid_points, ", "), ")"),
          {{"points_invalid", absl::StrCat(job.points_invalid)},
           {"points_received", absl::StrCat(job.points_received)},
           {"points_unrepresentable", absl::StrCat(unrepresentable)},
           {"first_invalid_points", absl::StrJoin(job.first_invalid_points, ",")}}};
}

// gRPC ends the server's stream at a request message that fails to parse exactly as at the
// client's half-close, without saying which; protobuf refuses a proto3 string that is not UTF-8.
// (absl::string_view: Debian's Abseil does not alias it to std::string_view.)
constexpr absl::string_view kUnparsed =
    "a message could not be parsed: a malformed encoding, or invalid UTF-8 in a string field "
    "such as job_id or scan_id";

absl::Status BadHeader(std::string_view field, std::string message) {
  return WithFieldViolation(absl::InvalidArgumentError(std::move(message)), "INVALID_HEADER",
                            field);
}

// A header string within kMaxHeaderStringBytes; `field` names it without echoing it.
absl::Status CheckString(std::string_view field, std::string_view what, const std::string& text) {
  if (text.size() <= kMaxHeaderStringBytes) return absl::OkStatus();
  return BadHeader(field,
                   absl::StrCat(std::string(field), ": ", std::string(what), " is ", text.size(),
                                " bytes long; at most ", kMaxHeaderStringBytes, " are accepted"));
}

// Checks that an optional per-point array is absent or has one value per point.
absl::Status CheckLength(uint64_t chunk, std::string_view name, int size, size_t n) {
  if (size == 0 || static_cast<size_t>(size) == n) return absl::OkStatus();
  return BadChunk(
      chunk, name,
      absl::StrCat(std::string(name), " has ", size, " values but xyz has ", n, " points"));
}

absl::Status CheckPresence(uint64_t chunk, std::string_view name, bool expected, bool present) {
  if (expected == present) return absl::OkStatus();
  return BadChunk(
      chunk, name,
      absl::StrCat(std::string(name), " is ", present ? "present" : "missing",
                   " but earlier chunks ",
                   expected ? "carried it" : "did not; an array must be in every chunk or none"));
}

}  // namespace

absl::Status JobAssembler::Add(const v1::ProcessRequest& request) {
  bytes_ += request.ByteSizeLong();
  if (bytes_ > limits_.max_bytes_per_call) {
    return WithReason(
        absl::ResourceExhaustedError(absl::StrCat(
            "the call's request messages total ", bytes_, " bytes, over the server's limit of ",
            limits_.max_bytes_per_call, " bytes per call (max_bytes_per_call)")),
        "CALL_TOO_LARGE");
  }
  if (ended_) {
    return WithFieldViolation(
        absl::InvalidArgumentError(
            absl::StrCat("a message after the end message (which declared ", job_.points_received,
                         " points); the end message must be the upload's last")),
        "INVALID_CHUNK", "end");
  }
  switch (request.kind_case()) {
    case v1::ProcessRequest::kHeader:
      return AddHeader(request.header());
    case v1::ProcessRequest::kPoints:
      return AddChunk(request.points());
    case v1::ProcessRequest::kEnd:
      return AddEnd(request.end());
    default:
      return has_header_ ? BadChunk(chunks_, "", "empty request message")
                         : BadHeader("header",
                                     "first message must be a header (got an empty request "
                                     "message)");
  }
}

absl::Status JobAssembler::AddHeader(const v1::JobHeader& header) {
  if (has_header_) {
    return BadHeader("header", absl::StrCat("a second header after ", chunks_,
                                            " chunks; a job has exactly one header"));
  }
  has_header_ = true;
  SCANPREP_RETURN_IF_ERROR(CheckHeaderSize(header));
  SCANPREP_ASSIGN_OR_RETURN(const double mm, MillimetresPerUnit(header.unit()));
  if (header.scans().empty()) {
    return BadHeader("header.scans", "header.scans: a job needs at least one scan");
  }
  job_.job_id = header.job_id();
  job_.mm_per_unit = mm;
  job_.include_removed = header.options().include_removed();
  job_.labels.insert(header.labels().begin(), header.labels().end());
  if (!v1::ArrayEncoding_IsValid(header.result_arrays())) {
    return BadHeader("header.result_arrays",
                     absl::StrCat("header.result_arrays: ", header.result_arrays(),
                                  " is no ArrayEncoding (REPEATED 1, PACKED 2, NONE 3)"));
  }
  job_.packed_results = header.result_arrays() == v1::ARRAY_ENCODING_PACKED;
  job_.return_points = header.result_arrays() != v1::ARRAY_ENCODING_NONE;
  job_.return_source_index = header.return_source_index();
  job_.options = OptionsFromHeader(header, limits_.default_budget_seconds,
                                   limits_.default_stage_budget_seconds);
  // The preset is resolved first, so that its values are validated, estimated and reported like
  // the job's own.
  auto params = ResolvePreset(*limits_.presets, header.options().preset(), job_.options.params);
  if (!params.ok()) return OptionsError(params.status());
  job_.options.params = *std::move(params);
  job_.preset = header.options().preset();
  auto fail_on = FailOnFromProto(header.options());
  if (!fail_on.ok()) return OptionsError(fail_on.status());
  job_.options.fail_on = *std::move(fail_on);
  if (absl::Status s = ValidateOptions(job_.options); !s.ok()) return OptionsError(s);
  SCANPREP_RETURN_IF_ERROR(CheckCost());

  SCANPREP_ASSIGN_OR_RETURN(const Eigen::Vector3d origin_mm, OriginFromProto(header, mm));
  for (int s = 0; s < header.scans_size(); ++s) {
    const std::string field = absl::StrCat("header.scans[", s, "]");
    SCANPREP_ASSIGN_OR_RETURN(const ScanFrame frame,
                              FrameFromProto(header.scans(s), mm, origin_mm, field));
    SCANPREP_ASSIGN_OR_RETURN(ScanMeta meta, ScanMetaFromProto(header.scans(s), frame, field));
    if (meta.id.empty()) meta.id = absl::StrCat("scan", s);
    frames_.push_back(frame);
    job_.cloud.scans.push_back(std::move(meta));
  }
  job_.cloud.kind = KindFromHeader(header);
  scan_points_.assign(job_.cloud.scans.size(), 0);
  scan_invalid_.assign(job_.cloud.scans.size(), 0);
  scan_unrepresentable_.assign(job_.cloud.scans.size(), 0);

  total_points_ = header.total_points();
  if (total_points_ == 0) {
    return BadHeader("header.total_points",
                     "header.total_points = 0: the number of points the upload will send must be "
                     "declared, so that a truncated upload is refused instead of processed");
  }
  if (total_points_ > limits_.max_points_per_job) {
    return WithReason(
        absl::ResourceExhaustedError(
            absl::StrCat("header.total_points = ", total_points_, " exceeds the server's limit of ",
                         limits_.max_points_per_job, " points per job (max_points_per_job)")),
        "JOB_TOO_LARGE");
  }
  return absl::OkStatus();
}

absl::Status JobAssembler::CheckCost() const {
  auto cost = EstimatePlanCost(job_.options);
  if (!cost.ok()) return OptionsError(cost.status());
  absl::Status refused = CheckPlanCost(*cost, limits_.max_plan_cost);
  if (refused.ok()) return refused;
  refused =
      WithMetadata(std::move(refused), "estimated_cost", absl::StrFormat("%.3g", cost->ratio));
  refused = WithMetadata(std::move(refused), "max_plan_cost",
                         absl::StrFormat("%.3g", limits_.max_plan_cost));
  return WithReason(std::move(refused), "JOB_TOO_COSTLY");
}

absl::Status JobAssembler::CheckHeaderSize(const v1::JobHeader& header) const {
  if (static_cast<uint64_t>(header.scans_size()) > limits_.max_scans_per_job) {
    return WithReason(
        absl::ResourceExhaustedError(absl::StrCat(
            "header.scans has ", header.scans_size(), " scans, over the server's limit of ",
            limits_.max_scans_per_job, " scans per job (max_scans_per_job)")),
        "TOO_MANY_SCANS");
  }
  const std::tuple<std::string_view, int, int> lists[] = {
      {"header.options.stages", header.options().stages_size(), kMaxHeaderListEntries},
      {"header.options.params", header.options().params_size(), kMaxHeaderListEntries},
      {"header.budget.stage_seconds", header.budget().stage_seconds_size(), kMaxHeaderListEntries},
      {"header.labels", header.labels_size(), kMaxLabels}};
  for (const auto& [field, size, most] : lists) {
    if (size > most) {
      return BadHeader(field, absl::StrCat(std::string(field), " has ", size, " entries; at most ",
                                           most, " are accepted"));
    }
  }
  SCANPREP_RETURN_IF_ERROR(CheckString("header.job_id", "the job id", header.job_id()));
  SCANPREP_RETURN_IF_ERROR(
      CheckString("header.options.preset", "the preset name", header.options().preset()));
  for (int i = 0; i < header.scans_size(); ++i) {
    SCANPREP_RETURN_IF_ERROR(CheckString(absl::StrCat("header.scans[", i, "].scan_id"),
                                         "the scan id", header.scans(i).scan_id()));
  }
  for (int i = 0; i < header.options().stages_size(); ++i) {
    SCANPREP_RETURN_IF_ERROR(CheckString(absl::StrCat("header.options.stages[", i, "]"),
                                         "the stage name", header.options().stages(i)));
  }
  // A long name is refused without naming its entry, which would echo it.
  for (const auto& [name, value] : header.options().params()) {
    SCANPREP_RETURN_IF_ERROR(CheckString("header.options.params", "a parameter name", name));
    SCANPREP_RETURN_IF_ERROR(
        CheckString(absl::StrCat("header.options.params['", name, "']"), "the value", value));
  }
  for (const auto& [name, seconds] : header.budget().stage_seconds()) {
    SCANPREP_RETURN_IF_ERROR(CheckString("header.budget.stage_seconds", "a stage name", name));
  }
  for (const auto& [key, value] : header.labels()) {
    SCANPREP_RETURN_IF_ERROR(CheckString("header.labels", "a label key", key));
    SCANPREP_RETURN_IF_ERROR(
        CheckString(absl::StrCat("header.labels['", key, "']"), "the value", value));
  }
  return absl::OkStatus();
}

absl::Status JobAssembler::CheckChunk(const v1::PointChunk& chunk, size_t n) const {
  const uint64_t id = chunks_;
  SCANPREP_RETURN_IF_ERROR(CheckLength(id, "scan_index", chunk.scan_index_size(), n));
  SCANPREP_RETURN_IF_ERROR(CheckLength(id, "scanline", chunk.scanline_size(), n));
  SCANPREP_RETURN_IF_ERROR(CheckLength(id, "quality", chunk.quality_size(), n));
  SCANPREP_RETURN_IF_ERROR(CheckLength(id, "intensity", chunk.intensity_size(), n));
  if (chunk.normal_size() > 0 || !chunk.flags().empty() || chunk.source_index_size() > 0) {
    const char* field = chunk.normal_size() > 0 ? "normal"
                        : chunk.flags().empty() ? "source_index"
                                                : "flags";
    return BadChunk(id, field, "normal, flags and source_index are result-only fields");
  }
  const size_t scans = job_.cloud.scans.size();
  if (n > 0 && chunk.scan_index_size() == 0 && scans > 1) {
    return BadChunk(
        id, "scan_index",
        absl::StrCat("scan_index is required because the header declares ", scans, " scans"));
  }
  for (int i = 0; i < chunk.scan_index_size(); ++i) {
    if (chunk.scan_index(i) >= scans) {
      return BadChunk(id, absl::StrCat("scan_index[", i, "]"),
                      absl::StrCat("scan_index[", i, "] = ", chunk.scan_index(i),
                                   " is not a scan declared in the header (", scans, " scans)"));
    }
  }
  for (int i = 0; i < chunk.quality_size(); ++i) {
    if (!(chunk.quality(i) >= 0.f && chunk.quality(i) <= 1.f)) {
      return BadChunk(id, absl::StrCat("quality[", i, "]"),
                      absl::StrCat("quality[", i, "] = ", chunk.quality(i), " is outside [0, 1]"));
    }
  }
  if (n > 0 && layout_known_) {
    SCANPREP_RETURN_IF_ERROR(
        CheckPresence(id, "scanline", has_scanline_, chunk.scanline_size() > 0));
    SCANPREP_RETURN_IF_ERROR(CheckPresence(id, "quality", has_quality_, chunk.quality_size() > 0));
    SCANPREP_RETURN_IF_ERROR(
        CheckPresence(id, "intensity", has_intensity_, chunk.intensity_size() > 0));
  }
  return absl::OkStatus();
}

absl::Status JobAssembler::AddChunk(const v1::PointChunk& chunk) {
  if (!has_header_) {
    return BadHeader("header", "first message must be a header (got points)");
  }
  if (HasPackedArrays(chunk)) {  // checked and read in the repeated form: one copy of ≤ 1 chunk
    v1::PointChunk unpacked = chunk;
    std::string bad_array;
    if (absl::Status s = UnpackArrays(unpacked, bad_array); !s.ok()) {
      return BadChunk(chunks_, bad_array, std::string(s.message()));
    }
    return AddChunk(unpacked);
  }
  if (chunk.xyz_size() % 3 != 0) {
    return BadChunk(chunks_, "xyz",
                    absl::StrCat("xyz has ", chunk.xyz_size(), " floats, not a multiple of 3"));
  }
  const size_t n = chunk.xyz_size() / 3;
  if (n > limits_.max_chunk_points) {
    return WithReason(absl::ResourceExhaustedError(absl::StrCat(
                          "chunk ", chunks_, ": ", n, " points exceed the limit of ",
                          limits_.max_chunk_points, " points per chunk (max_chunk_points)")),
                      "CHUNK_TOO_LARGE");
  }
  // The header's total is within max_points_per_job, so this also bounds the job.
  if (job_.points_received + n > total_points_) {
    return BadChunk(chunks_, "xyz",
                    absl::StrCat("more points than header.total_points = ", total_points_));
  }
  SCANPREP_RETURN_IF_ERROR(CheckChunk(chunk, n));
  checksum_.Add(chunk);
  ++chunks_;
  if (n == 0) return absl::OkStatus();
  if (!layout_known_) {
    layout_known_ = true;
    has_scanline_ = chunk.scanline_size() > 0;
    has_quality_ = chunk.quality_size() > 0;
    has_intensity_ = chunk.intensity_size() > 0;
  }

  PointCloud& cloud = job_.cloud;
  // Grown here, by the rule PeakBytesWith counts, not by push_back's own.
  if (const uint64_t capacity = CapacityFor(cloud.size() + n); capacity > cloud.x.capacity()) {
    for (std::vector<float>* a : {&cloud.x, &cloud.y, &cloud.z}) a->reserve(capacity);
    cloud.scan.reserve(capacity);
    if (has_scanline_) cloud.scanline.reserve(capacity);
    if (has_quality_) cloud.quality.reserve(capacity);
    if (has_intensity_) cloud.intensity.reserve(capacity);
  }
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d p(chunk.xyz(3 * i), chunk.xyz(3 * i + 1), chunk.xyz(3 * i + 2));
    const uint32_t scan = chunk.scan_index_size() > 0 ? chunk.scan_index(i) : 0;
    const Eigen::Vector3d q = frames_[scan].ChunkPoint(p);
    ++scan_points_[scan];
    SCANPREP_ASSIGN_OR_RETURN(const bool excluded, ExcludeInvalid(p, q, scan, i));
    if (excluded) continue;
    cloud.x.push_back(static_cast<float>(q.x()));
    cloud.y.push_back(static_cast<float>(q.y()));
    cloud.z.push_back(static_cast<float>(q.z()));
    cloud.scan.push_back(scan);
    if (has_scanline_) cloud.scanline.push_back(chunk.scanline(i));
    if (has_quality_) cloud.quality.push_back(chunk.quality(i));
    if (has_intensity_) cloud.intensity.push_back(chunk.intensity(i));
  }
  job_.points_received += n;
  return absl::OkStatus();
}

uint64_t JobAssembler::CapacityFor(uint64_t points) const {
  const uint64_t capacity = job_.cloud.x.capacity();
  if (points <= capacity) return capacity;
  return std::min(total_points_, std::max(points, 2 * capacity));
}

uint64_t JobAssembler::BytesPerHeldPoint() const {
  constexpr uint64_t kBytes = sizeof(float);  // each array's element: float or uint32_t
  if (!layout_known_) return 7 * kBytes;
  return kBytes * (4 + has_scanline_ + has_quality_ + has_intensity_);
}

uint64_t JobAssembler::PeakBytesWith(uint64_t more) const {
  const uint64_t held = job_.cloud.x.capacity();
  const uint64_t grown = CapacityFor(job_.cloud.size() + more);
  const uint64_t points = grown > held ? held + grown : held;
  // A left-out point's position is 8 bytes; push_back's growth at most triples the peak.
  const uint64_t positions = 3 * sizeof(uint64_t) * (job_.points_invalid + more);
  // Finish adds the flags, a byte a point.
  const uint64_t flags = job_.cloud.size() + more;
  return points * BytesPerHeldPoint() + positions + flags;
}

namespace {

// The coarsest float among a point's coordinates, in millimetres: as they arrived (`sent`, job
// units, relative to the scan's points_offset) and as they are held (`local_mm`, relative to
// header.origin). Either can be a lattice: a client that states an origin but sends absolute
// floats far from zero has already rounded them before the server sees them.
FloatPrecision CoarsestFloat(const Eigen::Vector3d& sent, double mm_per_unit,
                             const Eigen::Vector3d& local_mm) {
  FloatPrecision coarsest;
  for (int axis = 0; axis < 3; ++axis) {
    for (const bool as_sent : {false, true}) {  // on a tie, the origin's is the one to name
      const double value = as_sent ? sent[axis] : local_mm[axis];
      const double spacing = FloatSpacingAt(value) * (as_sent ? mm_per_unit : 1.0);
      if (!(spacing <= coarsest.spacing_mm)) {
        coarsest = {.axis = axis, .as_sent = as_sent, .value = value, .spacing_mm = spacing};
      }
    }
  }
  return coarsest;
}

}  // namespace

absl::StatusOr<bool> JobAssembler::ExcludeInvalid(const Eigen::Vector3d& sent,
                                                  const Eigen::Vector3d& local_mm, uint32_t scan,
                                                  size_t point) {
  // Finite in the request's unit can still overflow float once in millimetres.
  const bool in_range = (local_mm.array().abs() <= kMaxCoordinateMm).all();
  const double u = job_.cloud.scans[scan].uncertainty;
  const FloatPrecision coarsest = CoarsestFloat(sent, frames_[scan].mm_per_unit, local_mm);
  if (in_range && coarsest.spacing_mm <= kMaxFloatSpacingPerUncertainty * u) return false;
  if (job_.first_invalid_points.size() < kFirstInvalidPointsKept) {
    job_.first_invalid_points.push_back(job_.points_received + point);
  }
  job_.upload_positions.Exclude(job_.points_received + point);
  ++job_.points_invalid;
  ++job_.cloud.scans[scan].points_invalid;
  ++scan_invalid_[scan];
  if (!in_range) return true;
  ++job_.points_unrepresentable;
  ++scan_unrepresentable_[scan];
  // By the pigeonhole, a job over the share has a scan over it: refused before the rest arrives.
  if (job_.points_unrepresentable > kMaxUnrepresentableShare * total_points_) {
    return UnrepresentableError(coarsest, point, u);
  }
  return true;
}

absl::Status JobAssembler::UnrepresentableError(const FloatPrecision& coarsest, size_t point,
                                                double uncertainty_mm) const {
  const char axis = "xyz"[coarsest.axis];
  const std::string where =
      coarsest.as_sent
          ? absl::StrFormat(
                "its %c = %.17g as sent (job unit, from its scan's points_offset) was "
                "rounded by float before it arrived, coarser than",
                axis, coarsest.value)
          : absl::StrFormat("its %c = %.17g mm from header.origin cannot be held as a float to",
                            axis, coarsest.value);
  absl::Status status = BadChunk(
      chunks_ - 1, "xyz",
      absl::StrFormat("point %d: %s its scan's uncertainty %g mm (floats are %g mm apart there, "
                      "more than u/4), nor can %d of the job's %d points, more than %g %%: set "
                      "header.origin near the data, and send the points relative to their "
                      "scan's points_offset",
                      point, where, uncertainty_mm, coarsest.spacing_mm,
                      job_.points_unrepresentable, total_points_, 100 * kMaxUnrepresentableShare));
  status = WithMetadata(std::move(status), "point", absl::StrCat(point));
  status =
      WithMetadata(std::move(status), coarsest.as_sent ? "sent_coordinate" : "local_coordinate_mm",
                   absl::StrCat(coarsest.value));
  status = WithMetadata(std::move(status), "points_unrepresentable",
                        absl::StrCat(job_.points_unrepresentable));
  return WithMetadata(std::move(status), "float_spacing_mm", absl::StrCat(coarsest.spacing_mm));
}

absl::Status JobAssembler::CheckScansKeptPoints() const {
  for (size_t s = 0; s < job_.cloud.scans.size(); ++s) {
    const uint64_t received = scan_points_[s], invalid = scan_invalid_[s];
    const uint64_t far = scan_unrepresentable_[s];
    const bool none_kept = received > 0 && invalid == received;
    if (!none_kept && far <= kMaxUnrepresentableShare * received) continue;
    const ScanMeta& scan = job_.cloud.scans[s];
    absl::Status status = WithFieldViolation(
        absl::InvalidArgumentError(absl::StrFormat(
            "scan %d (%s): %d of its %d points are invalid, %d of them too far from "
            "header.origin for float to hold them to the scan's uncertainty %g mm; a scan must "
            "keep a valid point and have at most %g %% so far out%s",
            s, scan.id, invalid, received, far, scan.uncertainty, 100 * kMaxUnrepresentableShare,
            far > 0 ? ": set header.origin near the data, and send the points relative to "
                      "their scan's points_offset"
                    : "")),
        "INVALID_CHUNK", absl::StrCat("header.scans[", s, "]"));
    status = WithMetadata(std::move(status), "points_invalid", absl::StrCat(invalid));
    return WithMetadata(std::move(status), "points_unrepresentable", absl::StrCat(far));
  }
  return absl::OkStatus();
}

absl::Status JobAssembler::AddEnd(const v1::StreamEnd& end) {
  if (!has_header_) {
    return BadHeader("header", "first message must be a header (got the end message)");
  }
  if (end.points() != job_.points_received || end.points() != total_points_) {
    return WithFieldViolation(absl::InvalidArgumentError(absl::StrCat(
                                  "end.points = ", end.points(), " but ", job_.points_received,
                                  " points were received and header.total_points = ", total_points_,
                                  "; the three must agree")),
                              "POINT_COUNT_MISMATCH", "end.points");
  }
  if (end.crc32() != checksum_.crc32()) {
    // Corrupted on the way: the same upload can succeed again.
    return WithReason(absl::DataLossError(absl::StrFormat(
                          "end.crc32 = 0x%08x but the %d points received have CRC-32 0x%08x: "
                          "the upload was corrupted in transfer",
                          end.crc32(), job_.points_received, checksum_.crc32())),
                      "CHECKSUM_MISMATCH", absl::ZeroDuration());
  }
  ended_ = true;
  return absl::OkStatus();
}

absl::StatusOr<AssembledJob> JobAssembler::Finish() {
  if (!has_header_) {
    return WithFieldViolation(
        absl::InvalidArgumentError(absl::StrCat(
            "first message must be a header (the stream ended before one arrived: none was sent, "
            "or ",
            kUnparsed, ")")),
        "INCOMPLETE_UPLOAD", "header");
  }
  // gRPC ends a stream at a message that fails to parse just as at the client's half-close, so
  // only the end message tells a cut upload from a complete one.
  if (!ended_) {
    return WithFieldViolation(absl::InvalidArgumentError(absl::StrCat(
                                  "the upload ended without its end message after ",
                                  job_.points_received, " of header.total_points = ", total_points_,
                                  " points: the stream was cut (the client "
                                  "half-closed early, or ",
                                  kUnparsed, ")")),
                              "INCOMPLETE_UPLOAD", "end");
  }
  if (job_.points_invalid == job_.points_received) {
    return WithFieldViolation(
        absl::InvalidArgumentError(absl::StrCat(
            "the job has no valid points: all ", job_.points_received,
            " have NaN, infinite or out-of-range (> ", kMaxCoordinateMm, " mm) coordinates")),
        "INVALID_CHUNK", "points");
  }
  SCANPREP_RETURN_IF_ERROR(CheckScansKeptPoints());
  if (job_.points_invalid > 0) job_.warnings.push_back(PointsInvalidWarning(job_));
  // The upload's warnings fail a job that fails on them before any stage runs.
  SCANPREP_RETURN_IF_ERROR(
      FailedOnWarningError(FailOnWarnings(job_.warnings, job_.options.fail_on)));
  job_.cloud.FinishLoading();
  return std::move(job_);
}

}  // namespace scanprep::server

// SPDX-License-Identifier: Apache-2.0
// Validates a Process request stream message by message and assembles it into one job: the
// cloud in millimetres in the common frame plus the pipeline options. Pure logic, no gRPC, so it
// can be unit-tested and fuzzed.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/point_cloud.h"
#include "core/pipeline/pipeline.h"
#include "core/pipeline/presets.h"
#include "scanprep/v1/scanprep.pb.h"
#include "server/job/upload_positions.h"
#include "wire/convert.h"
#include "wire/stream_checksum.h"

namespace scanprep::server {

// Header lists (stages, parameters, stage budgets) longer than this are refused before they are
// copied: far more than the registry's stages and parameters, far less than a hostile 4 MiB header.
inline constexpr int kMaxHeaderListEntries = 256;
// Header strings (job and scan ids, stage and parameter names, parameter values) longer than this
// are refused: the report and error messages echo them, and with every list and string at its
// limit a report still fits far within gRPC's 4 MiB message limit (a 4 MB job_id made a report
// the client could not receive).
inline constexpr size_t kMaxHeaderStringBytes = 256;
// JobHeader.labels entries: the caller's own tags, echoed in the report.
inline constexpr int kMaxLabels = 32;

struct JobLimits {
  uint64_t max_points_per_job = 20'000'000;
  uint64_t max_chunk_points = 65'536;
  // Serialized size of all request messages of one call; the default fits a job at
  // max_points_per_job with every optional array (about 30 bytes per point).
  uint64_t max_bytes_per_call = uint64_t{1} << 30;
  // Largest single request message gRPC accepts: a stream's chunk or a whole ProcessUnary job
  // (held whole before its header is checked, and reserved as such).
  uint32_t max_message_bytes = 64 << 20;
  // Scans declared in one header; each costs a frame and metadata before any point arrives.
  uint32_t max_scans_per_job = 1'000;
  // The most work a job's plan may ask for, as a multiple of the default plan's
  // (core/pipeline/plan_cost.h); 0 = no limit. Each costly parameter alone at the edge of its
  // range is within 3x.
  double max_plan_cost = 3;
  double default_budget_seconds = 0;
  std::map<std::string, double> default_stage_budget_seconds;
  // What JobHeader.options.preset may name (presets_file.h); shared, not copied, by every call.
  std::shared_ptr<const std::vector<Preset>> presets =
      std::make_shared<const std::vector<Preset>>(BuiltinPresets());
};

struct AssembledJob {
  std::string job_id;
  PointCloud cloud;  // valid points only, mm, common frame less header.origin
  PipelineOptions options;
  bool include_removed = false;
  double mm_per_unit = 1.0;
  uint64_t points_received = 0;
  uint64_t points_invalid = 0;  // excluded: not finite, out of range or unrepresentable
  // Of points_invalid, those too far from header.origin for float to hold to their scan's u.
  uint64_t points_unrepresentable = 0;
  // Upload-order indices of the first excluded points (at most kFirstInvalidPointsKept).
  std::vector<uint64_t> first_invalid_points;
  std::vector<Warning> warnings;  // of the upload (POINTS_INVALID)
  std::map<std::string, std::string> labels;
  bool packed_results = false;       // header.result_arrays = ARRAY_ENCODING_PACKED
  bool return_points = true;         // false: header.result_arrays = ARRAY_ENCODING_NONE
  bool return_source_index = false;  // header.return_source_index
  UploadPositions upload_positions;  // each cloud point's position in the upload
  std::string preset;                // header.options.preset; its values are in options.params
};

// A scan (or, while uploading, the job) with more than this share of its points too far from
// header.origin for float is refused: a wrong origin, not a few stray returns, which are left out.
inline constexpr double kMaxUnrepresentableShare = 0.01;
// How many excluded points POINTS_INVALID names.
inline constexpr size_t kFirstInvalidPointsKept = 5;

// A point's coarsest float coordinate: its axis, whether as sent (job unit) or as held (mm from
// header.origin), its value and the spacing of floats there in millimetres.
struct FloatPrecision {
  int axis = 0;
  bool as_sent = false;
  double value = 0;
  double spacing_mm = 0;
};

class JobAssembler {
 public:
  explicit JobAssembler(JobLimits limits) : limits_(limits) {}

  // Takes the next request message; any error ends the call with that status.
  absl::Status Add(const v1::ProcessRequest& request);
  // After the stream ended: the job, or an error unless the upload ended with its StreamEnd.
  absl::StatusOr<AssembledJob> Finish();

  bool has_header() const { return has_header_; }
  const std::string& job_id() const { return job_.job_id; }
  uint64_t points_received() const { return job_.points_received; }
  // The client's declared total (0 until a header was accepted).
  uint64_t total_points() const { return total_points_; }
  // The pipeline options of the accepted header.
  const PipelineOptions& options() const { return job_.options; }
  // What the upload's arrays may hold once `more` points more have arrived: their storage, and
  // while they grow (together, doubling up to the declared total) the old storage beside the new,
  // plus the upload positions of left-out points and the flags Finish adds. Admission reserves it
  // (a ticket's memory while its call uploads), so it must never fall short of what the arrays
  // take.
  uint64_t PeakBytesWith(uint64_t more) const;

 private:
  absl::Status AddHeader(const v1::JobHeader& header);
  // The header's list and string lengths against the limits, before anything is copied from it.
  absl::Status CheckHeaderSize(const v1::JobHeader& header) const;
  // The resolved plan's estimated work within max_plan_cost (JOB_TOO_COSTLY).
  absl::Status CheckCost() const;
  absl::Status AddChunk(const v1::PointChunk& chunk);
  // The arrays' capacity once they hold `points`: doubling, at most the declared total.
  uint64_t CapacityFor(uint64_t points) const;
  // Bytes per point of the arrays the chunks carry (all of them until the first chunk says).
  uint64_t BytesPerHeldPoint() const;
  absl::Status CheckChunk(const v1::PointChunk& chunk, size_t n) const;
  // Leaves out point `point` of the chunk being read (of scan `scan`, as sent `sent`, local
  // coordinates `local_mm`) when it is not finite, out of range or unrepresentable (a float, as
  // sent or as held, cannot carry a coordinate to the scan's uncertainty,
  // kMaxFloatSpacingPerUncertainty); true if it did. An unrepresentable point is an error only
  // once more than kMaxUnrepresentableShare of the job's points are (the origin is wrong, not one
  // stray return).
  absl::StatusOr<bool> ExcludeInvalid(const Eigen::Vector3d& sent, const Eigen::Vector3d& local_mm,
                                      uint32_t scan, size_t point);
  // INVALID_CHUNK naming that point, its coarsest coordinate and the float spacing there, with the
  // origin hint.
  absl::Status UnrepresentableError(const FloatPrecision& coarsest, size_t point,
                                    double uncertainty_mm) const;
  // Each scan keeps a valid point and at most kMaxUnrepresentableShare unrepresentable ones.
  absl::Status CheckScansKeptPoints() const;
  // The client's count and CRC-32 against the header's total and the chunks received.
  absl::Status AddEnd(const v1::StreamEnd& end);

  JobLimits limits_;
  AssembledJob job_;
  std::vector<ScanFrame> frames_;
  bool has_header_ = false;
  uint64_t total_points_ = 0;
  uint64_t chunks_ = 0;
  uint64_t bytes_ = 0;       // serialized size of the messages so far
  StreamChecksum checksum_;  // over the accepted chunks
  bool ended_ = false;       // the StreamEnd arrived and matched
  // Which optional arrays the first non-empty chunk carried; later chunks must agree.
  bool layout_known_ = false;
  bool has_scanline_ = false, has_quality_ = false, has_intensity_ = false;
  // Per scan: the points received, of them those left out, and of those the unrepresentable
  // (ScanMeta::points_invalid also holds the rows the client left out, points_unmeasured).
  std::vector<uint64_t> scan_points_, scan_invalid_, scan_unrepresentable_;
};

}  // namespace scanprep::server

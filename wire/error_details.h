// SPDX-License-Identifier: Apache-2.0
// Standard gRPC error details: a stable reason (google.rpc.ErrorInfo, domain "scanprep.v1") on
// every refusal a program must tell apart, and google.rpc.RetryInfo only when the same call can
// succeed later. RESOURCE_EXHAUSTED means both "queue full, retry" (QUEUE_FULL, with RetryInfo)
// and "job too large, never retry" (JOB_TOO_LARGE, without); only the details say which.
//
// An INVALID_ARGUMENT also names the request field at fault (google.rpc.BadRequest), as a path
// in the request: "header.scans[1].scanline_spacing", "header.options.params['smoothing.lambda']",
// "points[3].xyz" (the fourth PointChunk message of the upload).
//
// A refusal is tagged where it arises, as payloads of its absl::Status, and ToGrpc turns them
// into the trailer gRPC sends (grpc-status-details-bin, a serialized google.rpc.Status).
#pragma once

#include <optional>
#include <string_view>

#include "absl/status/status.h"
#include "absl/time/time.h"

namespace grpc {
class Status;  // declared only, so the gRPC-free JobAssembler can tag its refusals
}  // namespace grpc

namespace scanprep {

inline constexpr std::string_view kErrorDomain = "scanprep.v1";

// A replica that is shutting down (SHUTTING_DOWN) asks for a retry after this: the service
// address then reaches another replica, or this one restarted.
inline constexpr absl::Duration kRetryOnAnotherReplica = absl::Seconds(1);

// `status` with the reason and, when a retry can succeed, the delay to wait first.
absl::Status WithReason(absl::Status status, std::string_view reason,
                        std::optional<absl::Duration> retry_after = std::nullopt);

// `status` with one more ErrorInfo metadata entry (e.g. the numbers behind a refusal).
absl::Status WithMetadata(absl::Status status, std::string_view key, std::string_view value);

// `status` with the reason and a field violation naming `field`, described by the message.
absl::Status WithFieldViolation(absl::Status status, std::string_view reason,
                                std::string_view field);

// A refused PipelineOptions (core's FieldError, or a stage's), tagged INVALID_PARAMETER with
// the field it names as a path in the request ("header." + the option's path).
absl::Status OptionsError(absl::Status status);

// A job failed on a warning (core's FailOnWarnings: PipelineOptions::fail_on), tagged with the
// warning's code as the reason (e.g. UNIT_SUSPECT: WarningCodeName) and its text ("message") and
// numbers as metadata; any other status unchanged.
absl::Status FailedOnWarningError(absl::Status status);

// The gRPC status, with ErrorInfo, RetryInfo and BadRequest details when `status` was tagged.
grpc::Status ToGrpc(const absl::Status& status);

}  // namespace scanprep

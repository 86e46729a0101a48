// Standard gRPC error details: a stable reason (google.rpc.ErrorInfo, domain "scanprep.v1") on
// every refusal a program must tell apart, and google.rpc.RetryInfo only when the same call can
// succeed later. RESOURCE_EXHAUSTED means both "queue full, retry" (QUEUE_FULL, with RetryInfo)
// and "job too large, never retry" (JOB_TOO_LARGE, without); only the details say which.
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

namespace scanprep::server {

inline constexpr std::string_view kErrorDomain = "scanprep.v1";

// `status` with the reason and, when a retry can succeed, the delay to wait first.
absl::Status WithReason(absl::Status status, std::string_view reason,
                        std::optional<absl::Duration> retry_after = std::nullopt);

// `status` with one more ErrorInfo metadata entry (e.g. the numbers behind a refusal).
absl::Status WithMetadata(absl::Status status, std::string_view key, std::string_view value);

// The gRPC status, with ErrorInfo and RetryInfo details when `status` was tagged.
grpc::Status ToGrpc(const absl::Status& status);

}  // namespace scanprep::server

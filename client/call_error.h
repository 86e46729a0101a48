// SPDX-License-Identifier: Apache-2.0
// What a failed call's standard error details say (google.rpc.ErrorInfo reason, RetryInfo delay,
// BadRequest field violations) and what the CLI makes of them: a line to print and an exit code a
// script can act on.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/time/time.h"

namespace grpc {
class Status;
}  // namespace grpc

namespace scanprep::client {

// `scanprep` exit codes (documented in docs/cli.md, "Exit codes").
enum ExitCode : int {
  kExitOk = 0,
  kExitFailure = 1,  // anything not below
  kExitUsage = 2,    // bad command line
  // The server said a retry can succeed (RetryInfo), or it was UNAVAILABLE, or the transfer was
  // corrupted (DATA_LOSS: a count or checksum mismatch on the way up or down).
  kExitRetryLater = 3,
  // INVALID_ARGUMENT, RESOURCE_EXHAUSTED without RetryInfo (too large), or FAILED_PRECONDITION
  // (the job failed on a warning it named in options.fail_on)
  kExitFixInput = 4,
  // `process --fail_on_budget_miss`: the job ran and its output was written, over its budget.
  kExitBudgetMissed = 5,
  // DEADLINE_EXCEEDED: the call's deadline (--timeout) passed before the job ended, or the server
  // expected the queue to outlast it; the server cancelled the job. Not "fix the input" nor a
  // local failure: allow more time, or send less.
  kExitTimedOut = 6,
};

struct FieldViolation {
  std::string field;  // a path in the request, e.g. "header.scans[1].scanline_spacing"
  std::string description;
};

struct CallErrorDetails {
  std::string reason;  // ErrorInfo.reason, e.g. "QUEUE_FULL"; empty when none was sent
  std::optional<absl::Duration> retry_delay;     // RetryInfo.retry_delay
  std::vector<FieldViolation> field_violations;  // BadRequest.field_violations
};

// The gRPC status as an absl::Status; its google.rpc.Status details travel as a payload.
absl::Status FromGrpc(const grpc::Status& status);

// The details FromGrpc kept (none for statuses not from the server).
CallErrorDetails DetailsOf(const absl::Status& status);

// " (reason QUEUE_FULL; retry after 1s)" or " (reason INVALID_CHUNK; field points[3].xyz)" with
// the parts that were sent; empty when none was. (A violation's description is the message.)
std::string DetailsText(const absl::Status& status);

// "CODE: message" followed by DetailsText.
std::string Describe(const absl::Status& status);

// kExitRetryLater, kExitFixInput, kExitTimedOut or kExitFailure for a failed call.
ExitCode ExitCodeFor(const absl::Status& status);

}  // namespace scanprep::client

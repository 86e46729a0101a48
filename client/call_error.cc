// SPDX-License-Identifier: Apache-2.0
#include "client/call_error.h"

#include <grpcpp/grpcpp.h>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"

namespace scanprep::client {
namespace {

// (absl::string_view: Debian's Abseil does not alias it to std::string_view.)
constexpr absl::string_view kDetailsPayload = "type.googleapis.com/google.rpc.Status";

}  // namespace

absl::Status FromGrpc(const grpc::Status& status) {
  absl::Status out(static_cast<absl::StatusCode>(status.error_code()), status.error_message());
  if (!out.ok() && !status.error_details().empty()) {
    out.SetPayload(kDetailsPayload, absl::Cord(status.error_details()));
  }
  return out;
}

CallErrorDetails DetailsOf(const absl::Status& status) {
  CallErrorDetails details;
  const auto payload = status.GetPayload(kDetailsPayload);
  google::rpc::Status rpc;
  if (!payload.has_value() || !rpc.ParseFromString(std::string(*payload))) return details;
  for (const google::protobuf::Any& any : rpc.details()) {
    google::rpc::ErrorInfo info;
    google::rpc::RetryInfo retry;
    google::rpc::BadRequest bad_request;
    if (any.UnpackTo(&info)) {
      details.reason = info.reason();
    } else if (any.UnpackTo(&retry)) {
      details.retry_delay = absl::Seconds(retry.retry_delay().seconds()) +
                            absl::Nanoseconds(retry.retry_delay().nanos());
    } else if (any.UnpackTo(&bad_request)) {
      for (const auto& violation : bad_request.field_violations()) {
        details.field_violations.push_back({violation.field(), violation.description()});
      }
    }
  }
  return details;
}

std::string DetailsText(const absl::Status& status) {
  const CallErrorDetails details = DetailsOf(status);
  std::vector<std::string> parts;
  if (!details.reason.empty()) parts.push_back("reason " + details.reason);
  if (details.retry_delay.has_value()) {
    parts.push_back("retry after " + absl::FormatDuration(*details.retry_delay));
  }
  for (const FieldViolation& violation : details.field_violations) {
    parts.push_back("field " + violation.field);
  }
  return parts.empty() ? "" : absl::StrCat(" (", absl::StrJoin(parts, "; "), ")");
}

std::string Describe(const absl::Status& status) {
  return absl::StrCat(absl::StatusCodeToString(status.code()), ": ", status.message(),
                      DetailsText(status));
}

ExitCode ExitCodeFor(const absl::Status& status) {
  const CallErrorDetails details = DetailsOf(status);
  if (details.retry_delay.has_value() || status.code() == absl::StatusCode::kUnavailable ||
      status.code() == absl::StatusCode::kDataLoss) {
    return kExitRetryLater;
  }
  // FAILED_PRECONDITION: the job failed on a warning its options.fail_on (--strict, --fail_on)
  // named; the input must change for it to pass.
  if (status.code() == absl::StatusCode::kInvalidArgument ||
      status.code() == absl::StatusCode::kResourceExhausted ||
      status.code() == absl::StatusCode::kFailedPrecondition) {
    return kExitFixInput;
  }
  if (status.code() == absl::StatusCode::kDeadlineExceeded) return kExitTimedOut;
  return kExitFailure;
}

}  // namespace scanprep::client

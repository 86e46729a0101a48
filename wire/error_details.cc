// SPDX-License-Identifier: Apache-2.0
#include "wire/error_details.h"

#include <string>

#include <grpcpp/grpcpp.h>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "core/base/field_error.h"
#include "core/stages/warning.h"
#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"

namespace scanprep {
namespace {

// Payload keys: private to this file, never sent as they are.
// (absl::string_view: Debian's Abseil does not alias it to std::string_view.)
constexpr absl::string_view kReasonPayload = "scanprep.v1/reason";
constexpr absl::string_view kRetryPayload = "scanprep.v1/retry_after_ms";
constexpr absl::string_view kFieldPayload = "scanprep.v1/field";
constexpr absl::string_view kMetadataPayloadPrefix = "scanprep.v1/metadata/";

}  // namespace

absl::Status WithReason(absl::Status status, std::string_view reason,
                        std::optional<absl::Duration> retry_after) {
  status.SetPayload(kReasonPayload, absl::Cord(std::string(reason)));
  if (retry_after.has_value()) {
    status.SetPayload(kRetryPayload,
                      absl::Cord(std::to_string(absl::ToInt64Milliseconds(*retry_after))));
  }
  return status;
}

absl::Status WithFieldViolation(absl::Status status, std::string_view reason,
                                std::string_view field) {
  status.SetPayload(kFieldPayload, absl::Cord(std::string(field)));
  return WithReason(std::move(status), reason);
}

absl::Status OptionsError(absl::Status status) {
  if (status.code() != absl::StatusCode::kInvalidArgument) return status;
  const std::string field = ErrorField(status);
  return WithFieldViolation(std::move(status), "INVALID_PARAMETER",
                            field.empty() ? "header.options" : absl::StrCat("header.", field));
}

absl::Status FailedOnWarningError(absl::Status status) {
  const std::optional<Warning> warning = FailedWarning(status);
  if (!warning) return status;
  status = WithMetadata(WithReason(std::move(status), WarningCodeName(warning->code)), "message",
                        warning->message);
  for (const auto& [key, value] : warning->params)
    status = WithMetadata(std::move(status), key, value);
  return status;
}

absl::Status WithMetadata(absl::Status status, std::string_view key, std::string_view value) {
  status.SetPayload(absl::StrCat(kMetadataPayloadPrefix, std::string(key)),
                    absl::Cord(std::string(value)));
  return status;
}

grpc::Status ToGrpc(const absl::Status& status) {
  const auto code = static_cast<grpc::StatusCode>(status.code());
  const std::string message(status.message());
  const auto reason = status.GetPayload(kReasonPayload);
  if (!reason.has_value()) return grpc::Status(code, message);

  google::rpc::Status details;
  details.set_code(static_cast<int>(code));
  details.set_message(message);
  google::rpc::ErrorInfo info;
  info.set_reason(std::string(*reason));
  info.set_domain(std::string(kErrorDomain));
  status.ForEachPayload([&](absl::string_view type_url, const absl::Cord& value) {
    if (absl::StartsWith(type_url, kMetadataPayloadPrefix)) {
      (*info.mutable_metadata())[std::string(type_url.substr(kMetadataPayloadPrefix.size()))] =
          std::string(value);
    }
  });
  details.add_details()->PackFrom(info);
  if (const auto retry = status.GetPayload(kRetryPayload)) {
    const int64_t ms = std::stoll(std::string(*retry));
    google::rpc::RetryInfo retry_info;
    retry_info.mutable_retry_delay()->set_seconds(ms / 1000);
    retry_info.mutable_retry_delay()->set_nanos(static_cast<int32_t>(ms % 1000) * 1'000'000);
    details.add_details()->PackFrom(retry_info);
  }
  if (const auto field = status.GetPayload(kFieldPayload)) {
    google::rpc::BadRequest bad_request;
    google::rpc::BadRequest::FieldViolation* violation = bad_request.add_field_violations();
    violation->set_field(std::string(*field));
    violation->set_description(message);
    details.add_details()->PackFrom(bad_request);
  }
  return grpc::Status(code, message, details.SerializeAsString());
}

}  // namespace scanprep

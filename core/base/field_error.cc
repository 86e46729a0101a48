// SPDX-License-Identifier: Apache-2.0
#include "core/base/field_error.h"

#include "absl/strings/str_cat.h"

namespace scanprep {
namespace {

// (absl::string_view: Debian's Abseil does not alias it to std::string_view.)
constexpr absl::string_view kFieldPayload = "scanprep/field";

}  // namespace

absl::Status FieldError(std::string_view field, std::string_view problem) {
  absl::Status status =
      absl::InvalidArgumentError(absl::StrCat(std::string(field), ": ", std::string(problem)));
  status.SetPayload(kFieldPayload, absl::Cord(std::string(field)));
  return status;
}

std::string ErrorField(const absl::Status& status) {
  const auto field = status.GetPayload(kFieldPayload);
  return field.has_value() ? std::string(*field) : std::string();
}

}  // namespace scanprep

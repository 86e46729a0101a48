// SPDX-License-Identifier: Apache-2.0
// The job file (`--job F`): a JobHeader in protobuf's JSON form, as an MES or `simulate` writes it.
#pragma once

#include <string>

#include "absl/status/statusor.h"
#include "scanprep/v1/scanprep.pb.h"

namespace scanprep::client {

// The JSON form of JobHeader (protobuf's JSON mapping; unknown fields are errors). Enum values
// are read by their proto names ("LENGTH_UNIT_MILLIMETRE"), by the names they had before they
// took their enum's prefix ("MILLIMETRE", "LINE") and, for "unit", by the --unit flag's short
// names ("mm", "m", "um", "in"). A value that is none of these is INVALID_ARGUMENT naming the
// field and listing the values it takes.
absl::StatusOr<scanprep::v1::JobHeader> ReadJobFile(const std::string& path);

}  // namespace scanprep::client

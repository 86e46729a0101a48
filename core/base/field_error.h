// SPDX-License-Identifier: Apache-2.0
// A refused option names the option at fault twice: in its message ("options.params['x']: ...")
// for people, and as a payload for programs, so an adapter (the gRPC server's
// google.rpc.BadRequest) can name the field without parsing the message.
#pragma once

#include <string>
#include <string_view>

#include "absl/status/status.h"

namespace scanprep {

// INVALID_ARGUMENT "<field>: <problem>", `field` being a path in PipelineOptions' terms, e.g.
// "options.params['smoothing.lambda']" or "budget.total_seconds".
absl::Status FieldError(std::string_view field, std::string_view problem);

// The field a FieldError names; empty for any other status.
std::string ErrorField(const absl::Status& status);

}  // namespace scanprep

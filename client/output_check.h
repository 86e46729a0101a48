// SPDX-License-Identifier: Apache-2.0
// An output file the command will write (-o, --preview, --report_json) checked before anything
// is read or sent: a job of minutes must not run only to find its result has nowhere to go.
#pragma once

#include <string>

#include "absl/status/status.h"

namespace scanprep::client {

// OK when `path` can be created or overwritten: its folder exists and is writable, and the path
// is no folder itself. Else FAILED_PRECONDITION naming the flag, the path and what is wrong. The
// file is not created.
absl::Status CheckWritable(const std::string& flag, const std::string& path);

}  // namespace scanprep::client

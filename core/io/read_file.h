// SPDX-License-Identifier: Apache-2.0
// Whole-file reads: every reader parses from one in-memory buffer, so no allocation can exceed
// the input's size and every parse step can be bounds-checked against it.
#pragma once

#include <filesystem>
#include <istream>
#include <string>

#include "absl/status/statusor.h"

namespace scanprep::io {

// NotFound when the file does not exist; InvalidArgument for a directory; Unavailable on I/O
// errors.
absl::StatusOr<std::string> ReadFileToString(const std::filesystem::path& path);
absl::StatusOr<std::string> ReadStreamToString(std::istream& in,
                                               const std::string& name_for_errors);

}  // namespace scanprep::io

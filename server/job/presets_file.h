// SPDX-License-Identifier: Apache-2.0
// The server's presets per scanner model, from --presets_file: one "[name]" section per preset,
// then its parameter overrides as "name = value" lines (the CLI's --param syntax) and optionally
// "description = text"; '#' starts a comment. Every override is validated at startup exactly as
// a job's would be, so a preset that loads is one a job can run.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/pipeline/presets.h"

namespace scanprep::server {

// The presets of a file's text, after the built-ins. INVALID_ARGUMENT "<source>:<line>: [preset]
// <key>: <problem>" for an unknown parameter, a value out of range, a key outside a section or
// given twice, a malformed line, a preset named twice or a name of a built-in, ignoring case (a
// file cannot silently redefine what "paper" means), more than 256 presets or a description over
// 256 bytes.
absl::StatusOr<std::vector<Preset>> ParsePresets(std::string_view text, std::string_view source);

// The built-ins when `path` is empty, else ParsePresets of the file: a regular file (a symlink to
// one, as a mounted ConfigMap is) of at most 1 MiB.
absl::StatusOr<std::vector<Preset>> LoadPresets(const std::string& path);

}  // namespace scanprep::server

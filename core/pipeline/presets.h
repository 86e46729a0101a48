// SPDX-License-Identifier: Apache-2.0
// Named sets of parameter overrides, so that a caller (an MES line, a scanner model) names one
// configuration instead of sending twenty parameters. A job's value of a parameter is its
// declared default, replaced by the preset's value, replaced by the job's own override.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/stages/params.h"

namespace scanprep {

struct Preset {
  std::string name;
  std::string description;
  ParamOverrides params;  // validated like a job's overrides
  bool built_in = false;
};

// The built-in presets: "metrology" (no overrides: the declared defaults, accuracy first) and
// "paper" (the paper's configuration: its global outlier rule alone and its weighted-mean
// smoothing, the fast one; docs/algorithms.md).
std::vector<Preset> BuiltinPresets();

// The preset's overrides checked against the declared parameters exactly as a job's are.
absl::Status ValidatePreset(const Preset& preset);

// The overrides a job runs with: `preset`'s (empty name = none), then `explicit_params` on top.
// An unknown name is INVALID_ARGUMENT naming the field "options.preset" and listing the names
// of `presets`.
absl::StatusOr<ParamOverrides> ResolvePreset(const std::vector<Preset>& presets,
                                             std::string_view preset,
                                             const ParamOverrides& explicit_params);

}  // namespace scanprep

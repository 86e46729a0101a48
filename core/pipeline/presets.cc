// SPDX-License-Identifier: Apache-2.0
#include "core/pipeline/presets.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/base/did_you_mean.h"
#include "core/base/field_error.h"
#include "core/stages/normals.h"
#include "core/stages/outliers.h"
#include "core/stages/smoothing.h"
#include "core/stages/stage.h"

namespace scanprep {

std::vector<Preset> BuiltinPresets() {
  return {
      {.name = "metrology",
       .description = "accuracy first: the declared defaults (the same as no preset)",
       .params = {},
       .built_in = true},
      // The paper's configuration: no surface test after the global outlier rule, smoothing by
      // the weighted mean of Eqs. 8-10 with moves over δ = u rejected; normals and smoothing from
      // the k-NN list, the paper's "k nearest neighbors (typically 20)", rather than the r_p ball
      // (the same accuracy for this configuration on the metrology scan, docs/benchmarks.md).
      {.name = "paper",
       .description = "the paper's configuration, the fast one: its outlier rule alone, "
                      "weighted-mean smoothing, k-NN neighbourhoods",
       .params = {OutliersParams().Override(&OutliersSettings::surface_sigmas, 0.0),
                  SmoothingParams().Override(&SmoothingSettings::method, SmoothingMethod::kMean),
                  NormalsParams().Override(&NormalsSettings::radius_mode, NormalsRadiusMode::kKnn),
                  SmoothingParams().Override(&SmoothingSettings::neighbourhood,
                                             SmoothingNeighbourhood::kKnn)},
       .built_in = true},
  };
}

absl::Status ValidatePreset(const Preset& preset) {
  return ValidateOverrides(preset.params, AllParamSpecs());
}

absl::StatusOr<ParamOverrides> ResolvePreset(const std::vector<Preset>& presets,
                                             std::string_view preset,
                                             const ParamOverrides& explicit_params) {
  if (preset.empty()) return explicit_params;
  const auto found = std::find_if(presets.begin(), presets.end(),
                                  [&](const Preset& p) { return p.name == preset; });
  if (found == presets.end()) {
    std::vector<std::string> known;
    for (const Preset& p : presets) known.push_back(p.name);
    return FieldError("options.preset", absl::StrCat("unknown preset '", std::string(preset), "'",
                                                     DidYouMean(preset, known),
                                                     " (known: ", absl::StrJoin(known, ", "), ")"));
  }
  ParamOverrides params = explicit_params;
  // insert() keeps an explicit value: the job's own override beats the preset's.
  params.insert(found->params.begin(), found->params.end());
  return params;
}

}  // namespace scanprep

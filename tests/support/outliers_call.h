// SPDX-License-Identifier: Apache-2.0
// The outlier stage's functions called as its plan runs them: RemoveOutliers on the neighbourhoods
// (and, for the nn rule's surface test, the normals) built before it; with LoOP and the surface
// test, then EstimateNormals on what LoOP left and RemoveSurfaceSpikes.
#pragma once

#include "core/stages/normals.h"
#include "core/stages/outliers.h"
#include "tests/support/stage_call.h"

namespace scanprep::testing {

inline absl::StatusOr<PipelineReport> RunOutlierFunctions(PointCloud& cloud,
                                                          const ParamOverrides& params = {}) {
  return CallStage(cloud, "outliers", params, [](StageInputs& in) {
    const OutliersSettings settings = in.Settings(OutliersParams());
    SCANPREP_RETURN_IF_ERROR(
        RemoveOutliers(in.cloud, in.measures, in.neighbourhoods, settings, in.out));
    if (!settings.loop() || settings.surface_sigmas == 0) return absl::OkStatus();
    SCANPREP_RETURN_IF_ERROR(EstimateNormals(in.cloud, in.measures, in.neighbourhoods,
                                             NormalsParams().Read(in.params), in.out));
    return RemoveSurfaceSpikes(in.cloud, in.measures, in.neighbourhoods, settings, in.out);
  });
}

}  // namespace scanprep::testing

// SPDX-License-Identifier: Apache-2.0
// The normals stage's function (EstimateNormals, with its unit check) called on the neighbourhoods
// its plan builds before it, for the tests of the normals, their orientation and the unit check.
#pragma once

#include "core/stages/normals.h"
#include "tests/support/stage_call.h"

namespace scanprep::testing {

inline absl::StatusOr<PipelineReport> RunNormalsFunction(PointCloud& cloud,
                                                         const ParamOverrides& params = {}) {
  return CallStage(cloud, "normals", params, [](StageInputs& in) {
    return EstimateNormals(in.cloud, in.measures, in.neighbourhoods, in.Settings(NormalsParams()),
                           in.out);
  });
}

}  // namespace scanprep::testing

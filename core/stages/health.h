// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>

#include "core/stages/param_table.h"
#include "core/stages/stage.h"
namespace scanprep {
// Scanner health (docs/health.md): per scan its noise σ̂, shares removed and viewing angles; per
// overlapping pair of scans the point-to-plane residuals and the rigid misalignment they imply.
// Reads the pipeline's measures and moves nothing; fills PipelineReport::health.
StageInfo HealthStageInfo();

// The parameters (HealthParams() declares them).
struct HealthSettings {
  size_t min_overlap_points = 0;  // fewer: nothing of the pair is solved
  double flat_ratio = 0;          // eigenvalue fraction below which a direction is unconstrained
  double max_pair_distance = 0;   // farthest partner, in the fixed scan's spacings
};
const ParamTable<HealthSettings>& HealthParams();
}  // namespace scanprep

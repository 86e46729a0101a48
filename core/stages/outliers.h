// SPDX-License-Identifier: Apache-2.0
#pragma once
#include "core/stages/stage.h"
namespace scanprep {
// Statistical outlier removal (paper §2.3, docs/algorithms.md §5).
StageInfo OutliersStageInfo();
// The step "outliers" expands to after LoOP's removals when the surface test is on: the surface
// test on normals fitted without LoOP's outliers. Not a stage a job can list.
StageInfo SurfaceSpikesStepInfo();
}  // namespace scanprep

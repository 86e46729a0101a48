// SPDX-License-Identifier: Apache-2.0
#pragma once

#include "core/stages/outliers_settings.h"
#include "core/stages/param_table.h"
#include "core/stages/stage.h"
namespace scanprep {
// Statistical outlier removal (paper §2.3, docs/algorithms.md §5).
StageInfo OutliersStageInfo();
// The internal stage "outliers" expands to after LoOP's removals when the surface test is on: the
// surface test on normals fitted without LoOP's outliers. Not a stage a job can list.
StageInfo SurfaceSpikesStageInfo();
// Its parameters: OutliersSettings' fields, each declared once.
const ParamTable<OutliersSettings>& OutliersParams();
}  // namespace scanprep

// SPDX-License-Identifier: Apache-2.0
#pragma once

#include "absl/status/status.h"
#include "core/base/point_cloud.h"
#include "core/base/point_measures.h"
#include "core/spatial/neighbourhoods.h"
#include "core/stages/outliers_settings.h"
#include "core/stages/param_table.h"
#include "core/stages/stage.h"
#include "core/stages/stage_reporter.h"

namespace scanprep {
// Statistical outlier removal (paper §2.3, docs/algorithms.md §5).
StageInfo OutliersStageInfo();
// The internal stage "outliers" expands to after LoOP's removals when the surface test is on: the
// surface test on normals fitted without LoOP's outliers. Not a stage a job can list.
StageInfo SurfaceSpikesStageInfo();
// Its parameters: OutliersSettings' fields, each declared once.
const ParamTable<OutliersSettings>& OutliersParams();
// The stage: the paper's d rule per scan (or LoOP) marks the far points, and the surface test
// (outliers.surface_sigmas > 0) keeps those on a supported plane and removes the spikes off it.
// The nn rule's surface test needs `m`'s normal fits; LoOP's runs in RemoveSurfaceSpikes, after
// normals fitted without LoOP's outliers.
absl::Status RemoveOutliers(PointCloud& cloud, const PointMeasures& m, const Neighbourhoods& nb,
                            const OutliersSettings& settings, StageReporter& out);
// The internal stage: the surface test alone.
absl::Status RemoveSurfaceSpikes(PointCloud& cloud, const PointMeasures& m,
                                 const Neighbourhoods& nb, const OutliersSettings& settings,
                                 StageReporter& out);
}  // namespace scanprep

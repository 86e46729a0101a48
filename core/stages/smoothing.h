// SPDX-License-Identifier: Apache-2.0
#pragma once

#include "absl/status/status.h"
#include "core/base/point_cloud.h"
#include "core/base/point_measures.h"
#include "core/spatial/neighbourhoods.h"
#include "core/stages/param_table.h"
#include "core/stages/smoothing_kernels.h"
#include "core/stages/stage.h"
#include "core/stages/stage_reporter.h"

namespace scanprep {
// Edge- and quality-preserving smoothing (paper §3.1, Eqs. 6-10; docs/algorithms.md §11).
StageInfo SmoothingStageInfo();
// Its parameters: SmoothingSettings' fields, each declared once.
const ParamTable<SmoothingSettings>& SmoothingParams();
// The stage: `iterations` Jacobi passes over `cloud`, each followed by `nb` moving with the points
// (Neighbourhoods::PointsMoved); σ̂ and δ derived per scan from `m`'s fit residuals unless
// `settings` forces them. Needs the measures stage's quality, curvature and fits.
absl::Status Smooth(PointCloud& cloud, const PointMeasures& m, Neighbourhoods& nb,
                    SmoothingSettings settings, StageReporter& out);
}  // namespace scanprep

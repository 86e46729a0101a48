// SPDX-License-Identifier: Apache-2.0
// The measures stage: viewing quality and curvature per point.
#pragma once

#include "absl/status/status.h"
#include "core/base/point_cloud.h"
#include "core/base/point_measures.h"
#include "core/spatial/neighbourhoods.h"
#include "core/stages/param_table.h"
#include "core/stages/stage.h"
#include "core/stages/stage_reporter.h"

namespace scanprep {
// Viewing quality q̂ (§8) and normalised curvature κ̂ (§9, Eq. 7) per point, into the job's
// PointMeasures; flags kEdge where κ̂ >= measures.edge_threshold. Requires "normals".
StageInfo MeasuresStageInfo();

// The curvature half's parameters (MeasuresParams() declares them).
struct MeasuresSettings {
  double scale = 0;            // s: scanline curvature of a significant edge
  double variation_scale = 0;  // s_σ: surface variation of one (fallback without scanlines)
  double edge_threshold = 0;   // κ̂ at or above which a point is an edge
  Derived<double> window;      // h for every scan, else derived per scan
};
const ParamTable<MeasuresSettings>& MeasuresParams();

// The stage: m.quality and m.curvature for every point (from `m`'s surface variation where a line
// scan has no scanlines), kEdge flags in `cloud`. `nb` gives the point spacing the curvature
// window is derived from (ScanPointSpacing; null: from the scanlines alone).
absl::Status ComputeMeasures(PointCloud& cloud, PointMeasures& m, const Neighbourhoods* nb,
                             const MeasuresSettings& settings, StageReporter& out);

}  // namespace scanprep

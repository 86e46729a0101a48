// SPDX-License-Identifier: Apache-2.0
// The measures stage: viewing quality and curvature per point.
#pragma once

#include "core/stages/param_table.h"
#include "core/stages/stage.h"

namespace scanprep {
// Viewing quality q̂ (§8) and normalised curvature κ̂ (§9, Eq. 7) per point, into
// StageContext::measures(); flags kEdge where κ̂ >= measures.edge_threshold. Requires "normals".
StageInfo MeasuresStageInfo();

// The curvature half's parameters (MeasuresParams() declares them).
struct MeasuresSettings {
  double scale = 0;            // s: scanline curvature of a significant edge
  double variation_scale = 0;  // s_σ: surface variation of one (fallback without scanlines)
  double edge_threshold = 0;   // κ̂ at or above which a point is an edge
  Derived<double> window;      // h for every scan, else derived per scan
};
const ParamTable<MeasuresSettings>& MeasuresParams();

}  // namespace scanprep

#pragma once
#include <vector>

#include "core/stage.h"
namespace scanprep {
// Viewing quality q̂ (§8) and normalised curvature κ̂ (§9, Eq. 7) per point, into
// JobContext::measures(); flags kEdge where κ̂ >= measures.edge_threshold. Requires "normals".
StageInfo MeasuresStageInfo();

// Δp per scan, the spacing of points along a scanline: measured (median consecutive distance)
// when the scan has scanlines, else the scanner's nominal point_spacing, else the median
// nearest-neighbour distance of the scan.
std::vector<double> ScanPointSpacing(JobContext& ctx);
}  // namespace scanprep

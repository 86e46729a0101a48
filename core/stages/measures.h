// SPDX-License-Identifier: Apache-2.0
// The measures stage: viewing quality and curvature per point, and the helpers other stages use
// to read them.
#pragma once

#include <algorithm>
#include <bit>
#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/point_cloud.h"
#include "core/stages/stage.h"

namespace scanprep {
// Viewing quality q̂ (§8) and normalised curvature κ̂ (§9, Eq. 7) per point, into
// StageContext::measures(); flags kEdge where κ̂ >= measures.edge_threshold. Requires "normals".
StageInfo MeasuresStageInfo();

// The stage's parameters, each name declared here once (its spec and its reader use these).
inline constexpr std::string_view kMeasuresCurvatureScale = "measures.curvature_scale_per_mm";
inline constexpr std::string_view kMeasuresVariationScale = "measures.variation_scale";
inline constexpr std::string_view kMeasuresEdgeThreshold = "measures.edge_threshold";
inline constexpr std::string_view kMeasuresWindow = "measures.window_mm";

// The direction from surface point p toward scan's camera (camera_position − p, or the line
// scanner's view_direction); none without either.
std::optional<Eigen::Vector3d> TowardCamera(const ScanMeta& scan, const Eigen::Vector3d& p);
// Angle in [0, π/2] between the unoriented normal n and a direction.
double ViewAngle(const Eigen::Vector3d& n, const Eigen::Vector3d& toward);

// Δp per scan, the spacing of points along a scanline: measured (median consecutive distance)
// when the scan has scanlines, else the scanner's nominal point_spacing, else the median
// nearest-neighbour distance of the scan. CANCELLED when the job's token fires.
absl::StatusOr<std::vector<double>> ScanPointSpacing(StageContext& ctx);

// Whether every unremoved point has the same q̂ (no scan had sensor poses or a per-point
// quality): then a weight or a choice by q̂ tells nothing apart.
bool UniformQuality(const PointCloud& cloud, const std::vector<float>& quality);

// A sort key of point i that orders by descending q̂, then by index, in its low 62 bits: q̂ in
// [0, 1] (anything else clamped) as 1 − q̂ in float bits, which non-negative floats order like.
// Sorting such keys beats a comparator that looks q̂ up by index, which would miss the cache on
// nearly every comparison of a million-point cloud.
inline uint64_t DescendingQualityKey(float quality, uint32_t i) {
  constexpr uint64_t kOne = std::bit_cast<uint32_t>(1.f);
  const uint64_t bits = quality > 0 ? std::bit_cast<uint32_t>(std::min(quality, 1.f)) : 0;
  return (kOne - bits) << 32 | i;
}
}  // namespace scanprep

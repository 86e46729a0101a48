// SPDX-License-Identifier: Apache-2.0
#pragma once
#include <string_view>

#include "core/stages/stage.h"
namespace scanprep {
// Scanner health (docs/health.md): per scan its noise σ̂, shares removed and viewing angles; per
// overlapping pair of scans the point-to-plane residuals and the rigid misalignment they imply.
// Reads the pipeline's measures and moves nothing; fills PipelineReport::health.
StageInfo HealthStageInfo();

// The stage's parameters, each name declared here once (its spec and its reader use these).
inline constexpr std::string_view kHealthMinOverlapPoints = "health.min_overlap_points";
inline constexpr std::string_view kHealthFlatRatio = "health.flat_ratio";
inline constexpr std::string_view kHealthMaxPairDistance = "health.max_pair_distance";
}  // namespace scanprep

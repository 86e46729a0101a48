// SPDX-License-Identifier: Apache-2.0
#pragma once
#include <string_view>

#include "core/stages/stage.h"
namespace scanprep {
// Statistical outlier removal (paper §2.3, docs/algorithms.md §5).
StageInfo OutliersStageInfo();
// The step "outliers" expands to after LoOP's removals when the surface test is on: the surface
// test on normals fitted without LoOP's outliers. Not a stage a job can list.
StageInfo SurfaceSpikesStepInfo();

// The stage's parameters, each name declared here once (its spec and its readers use these).
enum class OutlierMethod { kNn, kLoop };
inline constexpr ChoiceDecl<OutlierMethod, 2> kOutliersMethod{"outliers.method", {"nn", "loop"}};
inline constexpr std::string_view kOutliersK = "outliers.k";
inline constexpr std::string_view kOutliersMultiplier = "outliers.multiplier";
inline constexpr std::string_view kOutliersSurfaceSigmas = "outliers.surface_sigmas";
inline constexpr std::string_view kOutliersMedianFloor = "outliers.median_floor";
inline constexpr std::string_view kOutliersThreshold = "outliers.threshold_mm";
inline constexpr std::string_view kOutliersLoopK = "outliers.loop_k";
inline constexpr std::string_view kOutliersLoopLambda = "outliers.loop_lambda";
inline constexpr std::string_view kOutliersLoopThreshold = "outliers.loop_threshold";
}  // namespace scanprep

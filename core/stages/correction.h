// SPDX-License-Identifier: Apache-2.0
#pragma once
#include <string_view>

#include "core/stages/stage.h"
namespace scanprep {
// Quality-based merging of overlapping scans (paper §3.2, Eq. 11 and the removal rule called
// "Eq. 12" elsewhere in the project; docs/algorithms.md §10).
StageInfo CorrectionStageInfo();

// The stage's parameters, each name declared here once (its spec and its reader use these).
enum class CorrectionMode { kGather, kScatter };
inline constexpr ChoiceDecl<CorrectionMode, 2> kCorrectionMode{"correction.mode",
                                                               {"gather", "scatter"}};
inline constexpr std::string_view kCorrectionRounds = "correction.rounds";
inline constexpr std::string_view kCorrectionRadiusScale = "correction.radius_scale";
inline constexpr std::string_view kCorrectionRadius = "correction.radius_mm";
}  // namespace scanprep

// SPDX-License-Identifier: Apache-2.0
#pragma once
#include <string_view>

#include "core/stages/stage.h"
namespace scanprep {
// Curvature-adaptive or uniform thinning to a target spacing (paper §3.3, Eq. 13;
// docs/algorithms.md §12).
StageInfo SimplificationStageInfo();

// The stage's parameters, each name declared here once (its spec and its reader use these).
enum class SimplificationMode { kAdaptive, kUniform };
inline constexpr ChoiceDecl<SimplificationMode, 2> kSimplificationMode{"simplification.mode",
                                                                       {"adaptive", "uniform"}};
// sequential, the paper's one-by-one order (the default), or tiled: parallel, within 2 % of it in
// every zone of the metrology scan but 12 B/point more at its peak (docs/benchmarks.md).
enum class SimplificationOrder { kSequential, kTiled };
inline constexpr ChoiceDecl<SimplificationOrder, 2> kSimplificationOrder{"simplification.order",
                                                                         {"sequential", "tiled"}};
inline constexpr std::string_view kSimplificationSpacing = "simplification.spacing_mm";
inline constexpr std::string_view kSimplificationEdgeThreshold = "simplification.edge_threshold";
inline constexpr std::string_view kSimplificationCurvatureFloor = "simplification.curvature_floor";
}  // namespace scanprep

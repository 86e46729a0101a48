// SPDX-License-Identifier: Apache-2.0
#pragma once
#include <string_view>

#include "core/stages/stage.h"
namespace scanprep {
StageInfo NeighbourhoodsStageInfo();

// The stage's parameters, each name declared here once (its spec and its readers use these).
inline constexpr std::string_view kNeighbourhoodsK = "neighbourhoods.k";
inline constexpr std::string_view kNeighbourhoodsEpsilonU = "neighbourhoods.epsilon_u_mm";
inline constexpr std::string_view kNeighbourhoodsMinRadius = "neighbourhoods.min_radius_mm";
}  // namespace scanprep

// SPDX-License-Identifier: Apache-2.0
#pragma once
#include "core/stages/stage.h"
namespace scanprep {
// Curvature-adaptive or uniform thinning to a target spacing (paper §3.3, Eq. 13;
// docs/algorithms.md §12).
StageInfo SimplificationStageInfo();
}  // namespace scanprep

// SPDX-License-Identifier: Apache-2.0
#pragma once
#include "core/stages/stage.h"
namespace scanprep {
// Gaussian-weighted PCA normals (paper §2.2, Eq. 4; docs/algorithms.md §6) oriented by Eq. (3) or,
// without sensor poses, along a minimum spanning tree (Eq. 5, §7). Also fills the surface
// variation σ of every point into StageContext::measures().
StageInfo NormalsStageInfo();
}  // namespace scanprep

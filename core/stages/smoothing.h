// SPDX-License-Identifier: Apache-2.0
#pragma once

#include "core/stages/param_table.h"
#include "core/stages/smoothing_kernels.h"
#include "core/stages/stage.h"
namespace scanprep {
// Edge- and quality-preserving smoothing (paper §3.1, Eqs. 6-10; docs/algorithms.md §11).
StageInfo SmoothingStageInfo();
// Its parameters: SmoothingSettings' fields, each declared once.
const ParamTable<SmoothingSettings>& SmoothingParams();
}  // namespace scanprep

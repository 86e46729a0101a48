// SPDX-License-Identifier: Apache-2.0
#pragma once
#include "core/stages/stage.h"
namespace scanprep {
// Quality-based merging of overlapping scans (paper §3.2, Eq. 11 and the removal rule called
// "Eq. 12" elsewhere in the project; docs/algorithms.md §10).
StageInfo CorrectionStageInfo();
}  // namespace scanprep

// SPDX-License-Identifier: Apache-2.0
#pragma once
#include "core/pipeline/stage.h"
namespace scanprep {
// Statistical outlier removal (paper §2.3, docs/algorithms.md §5).
StageInfo OutliersStageInfo();
}  // namespace scanprep

// SPDX-License-Identifier: Apache-2.0
#pragma once
#include "core/pipeline/stage.h"
namespace scanprep {
StageInfo NeighbourhoodsStageInfo();
}

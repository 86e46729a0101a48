// SPDX-License-Identifier: Apache-2.0
#pragma once
#include "core/stages/stage.h"
namespace scanprep {
StageInfo NeighbourhoodsStageInfo();
}

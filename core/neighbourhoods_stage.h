#pragma once
#include "core/stage.h"
namespace scanprep {
StageInfo NeighbourhoodsStageInfo();
}

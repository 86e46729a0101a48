// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstdint>

#include "core/stages/param_table.h"
#include "core/stages/stage.h"
namespace scanprep {
StageInfo NeighbourhoodsStageInfo();

// The parameters (NeighbourhoodsParams() declares them).
struct NeighbourhoodsSettings {
  uint32_t k = 0;              // neighbours per point in the shared graph
  Derived<double> epsilon_u;   // ε_u of Eq. (2), each scan's u unless set
  Derived<double> min_radius;  // r_min of Eq. (2), per scan unless set
};
const ParamTable<NeighbourhoodsSettings>& NeighbourhoodsParams();
}  // namespace scanprep

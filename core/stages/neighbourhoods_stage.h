// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

#include "absl/status/statusor.h"
#include "core/base/point_cloud.h"
#include "core/spatial/neighbourhoods.h"
#include "core/stages/param_table.h"
#include "core/stages/stage.h"
#include "core/stages/stage_reporter.h"

namespace scanprep {
// The shared k-NN graph and per-point radii every later stage reads (docs/algorithms.md §4).
StageInfo NeighbourhoodsStageInfo();

// The parameters (NeighbourhoodsParams() declares them).
struct NeighbourhoodsSettings {
  uint32_t k = 0;              // neighbours per point in the shared graph
  Derived<double> epsilon_u;   // ε_u of Eq. (2), each scan's u unless set
  Derived<double> min_radius;  // r_min of Eq. (2), per scan unless set
};
const ParamTable<NeighbourhoodsSettings>& NeighbourhoodsParams();

// The stage: the graph over `cloud` with r_min per scan (Eq. 2), held to the data's own scale.
// `duplicates_collapsed` (the job's, collapsed before the first stage) is reported and warned of.
absl::StatusOr<std::unique_ptr<Neighbourhoods>> BuildNeighbourhoods(
    const PointCloud& cloud, const NeighbourhoodsSettings& settings, size_t duplicates_collapsed,
    StageReporter& out);
}  // namespace scanprep

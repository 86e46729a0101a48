// SPDX-License-Identifier: Apache-2.0
#pragma once

#include "absl/status/statusor.h"
#include "core/base/point_cloud.h"
#include "core/base/point_measures.h"
#include "core/spatial/neighbourhoods.h"
#include "core/stages/param_table.h"
#include "core/stages/stage.h"
#include "core/stages/stage_reporter.h"

namespace scanprep {
// Quality-based merging of overlapping scans (paper §3.2, Eq. 11 and the removal rule called
// "Eq. 12" elsewhere in the project; docs/algorithms.md §10).
StageInfo CorrectionStageInfo();

// gather: each point decides from its own neighbourhood; scatter: the paper's order.
enum class CorrectionMode { kGather, kScatter };

// The parameters (CorrectionParams() declares them).
struct CorrectionSettings {
  CorrectionMode mode = CorrectionMode::kGather;
  int rounds = 0;  // gather: the most rounds
  double radius_scale = 0;
  Derived<double> radius;  // r_c for every scan, else derived per scan (Eq. 11)
};
const ParamTable<CorrectionSettings>& CorrectionParams();

// The stage: marks kRemovedMerge on the points of overlapping scans the rule removes, by `m`'s
// viewing quality. False when there was nothing to merge (one scan, or every quality the same:
// recorded and warned about) and `settings` went unused.
absl::StatusOr<bool> CorrectOverlaps(PointCloud& cloud, const PointMeasures& m,
                                     const Neighbourhoods& nb, const CorrectionSettings& settings,
                                     StageReporter& out);
}  // namespace scanprep

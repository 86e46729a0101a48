// SPDX-License-Identifier: Apache-2.0
#pragma once

#include "absl/status/status.h"
#include "core/base/point_cloud.h"
#include "core/base/point_measures.h"
#include "core/spatial/neighbourhoods.h"
#include "core/stages/param_table.h"
#include "core/stages/stage.h"
#include "core/stages/stage_reporter.h"

namespace scanprep {
// Curvature-adaptive or uniform thinning to a target spacing (paper §3.3, Eq. 13;
// docs/algorithms.md §12).
StageInfo SimplificationStageInfo();

enum class SimplificationMode { kAdaptive, kUniform };
// sequential, the paper's one-by-one order (the default), or tiled: parallel, within 2 % of it in
// every zone of the metrology scan but 12 B/point more at its peak (docs/benchmarks.md).
enum class SimplificationOrder { kSequential, kTiled };

// The parameters (SimplificationParams() declares them).
struct SimplificationSettings {
  SimplificationMode mode = SimplificationMode::kAdaptive;
  Derived<double> spacing;  // r_s, derived from the scanners' pitch unless set
  double edge_threshold = 0;
  double curvature_floor = 0;
  SimplificationOrder order = SimplificationOrder::kSequential;
};
const ParamTable<SimplificationSettings>& SimplificationParams();

// The stage: marks kRemovedSimplify on the points thinned away, by `m`'s curvature and quality.
absl::Status Simplify(PointCloud& cloud, const PointMeasures& m, const Neighbourhoods& nb,
                      const SimplificationSettings& settings, StageReporter& out);
}  // namespace scanprep

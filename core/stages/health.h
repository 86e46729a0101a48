// SPDX-License-Identifier: Apache-2.0
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/point_cloud.h"
#include "core/base/point_measures.h"
#include "core/spatial/neighbourhoods.h"
#include "core/stages/health_report.h"
#include "core/stages/param_table.h"
#include "core/stages/stage.h"
#include "core/stages/stage_reporter.h"

namespace scanprep {
// Scanner health (docs/health.md): per scan its noise σ̂, shares removed and viewing angles; per
// overlapping pair of scans the point-to-plane residuals and the rigid misalignment they imply.
// Reads the pipeline's measures and moves nothing; fills PipelineReport::health.
StageInfo HealthStageInfo();

// The parameters (HealthParams() declares them).
struct HealthSettings {
  size_t min_overlap_points = 0;  // fewer: nothing of the pair is solved
  double max_standard_error = 0;  // share of the residual spread a constrained component's
                                  // standard error may reach
  double max_pair_distance = 0;   // farthest partner, in the fixed scan's spacings
};
const ParamTable<HealthSettings>& HealthParams();

// Which removing stages ran before health: a share they could not have removed reads as unknown.
struct RemovalStagesRun {
  bool outliers = false;
  bool correction = false;
};

// Every overlapping pair's residuals and misalignment (fixed < moving), at the points' present
// positions, from `m`'s normal fits.
absl::StatusOr<std::vector<PairHealth>> MeasurePairs(const PointCloud& cloud,
                                                     const PointMeasures& m,
                                                     const Neighbourhoods& nb,
                                                     const HealthSettings& settings,
                                                     const CancelToken& cancel);

// The stage: every scan's figures and every overlapping pair's, from `m`'s normal fits. The pairs
// are `measured_pairs` where the registration stage measured them before it moved the scans (so
// the report shows the sensors' misalignment, not what is left of it), else measured here.
absl::StatusOr<HealthReport> MeasureHealth(
    const PointCloud& cloud, const PointMeasures& m, const Neighbourhoods& nb,
    const HealthSettings& settings, const RemovalStagesRun& ran, StageReporter& out,
    std::optional<std::vector<PairHealth>> measured_pairs = std::nullopt);
}  // namespace scanprep

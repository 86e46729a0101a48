// SPDX-License-Identifier: Apache-2.0
#pragma once
#include "core/base/point_cloud.h"
#include "core/spatial/neighbourhoods.h"
#include "core/stages/outliers_settings.h"
#include "core/stages/stage_reporter.h"
namespace scanprep {
// Local Outlier Probabilities (Kriegel et al. 2009; docs/algorithms.md §5), the outlier stage's
// `outliers.method = loop`: labels points with LoOP > outliers.loop_threshold as kRemovedOutlier.
// Local, so it copes with density that varies between sensors or regions.
absl::Status RemoveLoopOutliers(PointCloud& cloud, const Neighbourhoods& nb,
                                const OutliersSettings& settings, StageReporter& out);
}  // namespace scanprep

// SPDX-License-Identifier: Apache-2.0
#pragma once
#include "core/spatial/neighbourhoods.h"
#include "core/stages/outliers_settings.h"
#include "core/stages/stage_context.h"
namespace scanprep {
// Local Outlier Probabilities (Kriegel et al. 2009; docs/algorithms.md §5), the outlier stage's
// `outliers.method = loop`: labels points with LoOP > outliers.loop_threshold as kRemovedOutlier.
// Local, so it copes with density that varies between sensors or regions.
absl::Status RemoveLoopOutliers(StageContext& ctx, const Neighbourhoods& nb,
                                const OutliersSettings& settings);
}  // namespace scanprep

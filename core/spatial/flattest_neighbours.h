// SPDX-License-Identifier: Apache-2.0
// The neighbours whose normal fits are the flattest (lowest surface variation): their tangent
// planes are the candidates for "the surface here", as used by smoothing's own-side plane and by
// the outliers' surface test. Near an edge, the flattest ones lie on the faces, not on the edge.
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/base/point_cloud.h"
#include "core/base/point_measures.h"
#include "core/spatial/neighbourhoods.h"

namespace scanprep {

// Fills `out` with up to `count` (surface variation, index) of the matches with a valid normal,
// other than `exclude`, flattest first.
void FlattestNeighbours(const PointCloud& cloud, const PointMeasures& m,
                        const RadiusMatches& matches, size_t exclude, size_t count,
                        std::vector<std::pair<float, uint32_t>>& out);

}  // namespace scanprep

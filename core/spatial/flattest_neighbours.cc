// SPDX-License-Identifier: Apache-2.0
#include "core/spatial/flattest_neighbours.h"

#include <algorithm>

namespace scanprep {

void FlattestNeighbours(const PointCloud& cloud, const PointMeasures& m,
                        const RadiusMatches& matches, size_t exclude, size_t count,
                        std::vector<std::pair<float, uint32_t>>& out) {
  out.clear();
  for (const auto& [j, d2] : matches) {
    if (j != exclude && !(cloud.flags[j] & kNormalInvalid)) {
      out.emplace_back(m.surface_variation[j], j);
    }
  }
  const size_t take = std::min(count, out.size());
  std::partial_sort(out.begin(), out.begin() + take, out.end());
  out.resize(take);
}

}  // namespace scanprep

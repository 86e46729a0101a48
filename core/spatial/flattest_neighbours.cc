// SPDX-License-Identifier: Apache-2.0
#include "core/spatial/flattest_neighbours.h"

#include <algorithm>

namespace scanprep {

void FlattestNeighbours(const PointCloud& cloud, const PointMeasures& m,
                        const RadiusMatches& matches, size_t exclude, size_t count,
                        std::vector<std::pair<float, uint32_t>>& out) {
  out.clear();
  if (count == 0) return;
  // A sorted list of at most `count`, each match inserted in place: once it is full most matches
  // lose to its last with one comparison (a partial sort of all of them kept a heap).
  for (const auto& [j, d2] : matches) {
    if (j == exclude || (cloud.flags[j] & kNormalInvalid)) continue;
    const std::pair<float, uint32_t> item(m.surface_variation[j], j);
    if (out.size() == count) {
      if (!(item < out.back())) continue;
      out.pop_back();
    }
    out.insert(std::upper_bound(out.begin(), out.end(), item), item);
  }
}

}  // namespace scanprep
